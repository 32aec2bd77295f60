// How the `mvbrdf` commands that talk to a server (submit, watch, fetch,
// jobs, cancel, worker) connect: the channel's transport (plaintext or TLS,
// optionally with a client certificate) and the bearer token every call
// carries (docs/service.md "Security"). One place, so every command takes
// the same flags.
//
// The token comes from --token-file FILE, else from the environment variable
// MVBRDF_TOKEN, else there is none (a server without tokens needs none). It
// is never taken on the command line (it would show in `ps`) and never
// printed. The channel attaches "authorization: Bearer <token>" to every
// call through a client interceptor, so callers create their
// grpc::ClientContexts as before.
#ifndef MVBRDF_CLIENT_CONNECTION_H_
#define MVBRDF_CLIENT_CONNECTION_H_

#include <grpcpp/grpcpp.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/flags.h"

namespace mvbrdf::client {

struct ConnectionFlags {
  std::string token_file;       // --token-file
  bool tls = false;             // --tls: TLS trusting the system's roots
  std::string tls_ca;           // --tls-ca: TLS trusting this CA (PEM)
  std::string tls_cert;         // --tls-cert: client certificate (mutual TLS)
  std::string tls_key;          // --tls-key: its private key
  std::string tls_server_name;  // --tls-server-name: the name the server's certificate must carry
};

void AddConnectionFlags(FlagParser& flags, ConnectionFlags* connection);

// The token to send (empty: none). INVALID_ARGUMENT naming the flag or the
// variable for an unreadable or empty file or a token that is not printable
// ASCII without spaces.
absl::StatusOr<std::string> ResolveToken(const ConnectionFlags& connection);

// Checks a label the client sends to the server in gRPC metadata or as a
// name (--client, worker --name): 1 to 128 bytes of printable ASCII
// (0x20..0x7E, what an HTTP/2 header value may hold) without leading or
// trailing spaces. gRPC aborts the process on a metadata value with other
// bytes ("café", a newline, a tab), so they are refused here, naming `flag`,
// rather than percent-encoded: the label names the caller's jobs, and an
// encoded one would list under a name the user never typed.
absl::Status CheckLabel(absl::string_view value, absl::string_view flag);

// A channel to `address` with the transport and token of `connection` that
// accepts the service's largest messages. Errors name the flag.
absl::StatusOr<std::shared_ptr<grpc::Channel>> OpenChannel(const std::string& address,
                                                           const ConnectionFlags& connection);

// For the one-shot client commands: drops gRPC's own log lines (e.g.
// "Handshake failed ... certificate verify failed"), which repeat what the
// command's one-line error says, unless GRPC_VERBOSITY or GRPC_TRACE is set.
// Call once, before the first channel.
void QuietGrpcLog();

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_CONNECTION_H_
