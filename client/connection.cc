#include "client/connection.h"

#include <grpc/support/log.h>
#include <grpcpp/support/client_interceptor.h>

#include <cstdlib>
#include <utility>
#include <vector>

#include "absl/strings/ascii.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf::client {
namespace {

// What the server may send us at most (artifact and Sample chunks are 1 MiB).
constexpr int kMaxReceiveBytes = 16 << 20;

// Adds the bearer token to every call's initial metadata.
class BearerInterceptor final : public grpc::experimental::Interceptor {
 public:
  explicit BearerInterceptor(const std::string* header) : header_(header) {}
  void Intercept(grpc::experimental::InterceptorBatchMethods* methods) override {
    if (methods->QueryInterceptionHookPoint(grpc::experimental::InterceptionHookPoints::PRE_SEND_INITIAL_METADATA)) {
      methods->GetSendInitialMetadata()->emplace("authorization", *header_);
    }
    methods->Proceed();
  }

 private:
  const std::string* const header_;  // owned by the factory, which the channel keeps
};

class BearerInterceptorFactory final : public grpc::experimental::ClientInterceptorFactoryInterface {
 public:
  explicit BearerInterceptorFactory(const std::string& token) : header_(absl::StrCat("Bearer ", token)) {}
  grpc::experimental::Interceptor* CreateClientInterceptor(grpc::experimental::ClientRpcInfo* /*info*/) override {
    return new BearerInterceptor(&header_);
  }

 private:
  const std::string header_;
};

absl::StatusOr<std::string> ReadPem(const std::string& path, absl::string_view flag) {
  absl::StatusOr<std::string> text = ReadFileToString(path);
  if (!text.ok()) return absl::InvalidArgumentError(absl::StrCat(flag, ": ", path, ": cannot read"));
  if (text->find("-----BEGIN ") == std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": ", path, ": not a PEM file"));
  }
  return text;
}

absl::Status CheckToken(absl::string_view token, absl::string_view origin) {
  if (token.empty()) return absl::InvalidArgumentError(absl::StrCat(origin, ": the token is empty"));
  // gRPC refuses metadata over its size limit (8 KiB by default) with an
  // unhelpful "metadata size exceeds limit" (exit 4); a token is far shorter.
  constexpr size_t kMaxTokenBytes = 4096;
  if (token.size() > kMaxTokenBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(origin, ": the token must be at most ", kMaxTokenBytes, " characters, got ", token.size()));
  }
  for (char c : token) {
    if (c <= ' ' || c > '~') {
      return absl::InvalidArgumentError(
          absl::StrCat(origin, ": the token must be printable ASCII without spaces (one token, one line)"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

absl::Status CheckLabel(absl::string_view value, absl::string_view flag) {
  constexpr size_t kMaxLabelBytes = 128;
  if (value.empty() || value.size() > kMaxLabelBytes) {
    return absl::InvalidArgumentError(
        absl::StrCat(flag, ": must be 1 to ", kMaxLabelBytes, " characters, got ", value.size()));
  }
  for (char c : value) {
    if (c < ' ' || c > '~') {
      return absl::InvalidArgumentError(
          absl::StrCat(flag, ": must be printable ASCII (letters, digits, punctuation, spaces), got \"",
                       absl::CHexEscape(value), "\""));
    }
  }
  if (value.front() == ' ' || value.back() == ' ') {
    return absl::InvalidArgumentError(absl::StrCat(flag, ": must not start or end with a space, got \"", value, "\""));
  }
  return absl::OkStatus();
}

void AddConnectionFlags(FlagParser& flags, ConnectionFlags* connection) {
  flags.AddString("--token-file FILE", &connection->token_file,
                  "file holding the bearer token (default: the environment variable MVBRDF_TOKEN)");
  flags.AddBool("--tls", &connection->tls, "connect with TLS, trusting the system's root certificates");
  flags.AddString("--tls-ca FILE", &connection->tls_ca, "connect with TLS, trusting this CA certificate (PEM)");
  flags.AddString("--tls-cert FILE", &connection->tls_cert, "client certificate for mutual TLS (PEM)");
  flags.AddString("--tls-key FILE", &connection->tls_key, "private key of --tls-cert (PEM)");
  flags.AddString("--tls-server-name NAME", &connection->tls_server_name,
                  "the name the server's certificate must carry (default: the host of --server)");
}

absl::StatusOr<std::string> ResolveToken(const ConnectionFlags& connection) {
  if (!connection.token_file.empty()) {
    absl::StatusOr<std::string> text = ReadFileToString(connection.token_file);
    if (!text.ok())
      return absl::InvalidArgumentError(absl::StrCat("--token-file: ", connection.token_file, ": cannot read"));
    const std::string token(absl::StripAsciiWhitespace(*text));
    MVBRDF_RETURN_IF_ERROR(CheckToken(token, absl::StrCat("--token-file: ", connection.token_file)));
    return token;
  }
  const char* env = std::getenv("MVBRDF_TOKEN");
  if (env == nullptr || *env == '\0') return std::string();
  const std::string token(absl::StripAsciiWhitespace(env));
  MVBRDF_RETURN_IF_ERROR(CheckToken(token, "MVBRDF_TOKEN"));
  return token;
}

absl::StatusOr<std::shared_ptr<grpc::Channel>> OpenChannel(const std::string& address,
                                                           const ConnectionFlags& connection) {
  if (connection.tls_cert.empty() != connection.tls_key.empty()) {
    return absl::InvalidArgumentError("--tls-cert, --tls-key: give both or neither");
  }
  const bool tls = connection.tls || !connection.tls_ca.empty() || !connection.tls_cert.empty();
  if (!tls && !connection.tls_server_name.empty()) {
    return absl::InvalidArgumentError("--tls-server-name: needs TLS (--tls or --tls-ca)");
  }
  grpc::ChannelArguments args;
  args.SetMaxReceiveMessageSize(kMaxReceiveBytes);
  std::shared_ptr<grpc::ChannelCredentials> credentials = grpc::InsecureChannelCredentials();
  if (tls) {
    grpc::SslCredentialsOptions ssl;
    if (!connection.tls_ca.empty()) {
      MVBRDF_ASSIGN_OR_RETURN(ssl.pem_root_certs, ReadPem(connection.tls_ca, "--tls-ca"));
    }
    if (!connection.tls_cert.empty()) {
      MVBRDF_ASSIGN_OR_RETURN(ssl.pem_cert_chain, ReadPem(connection.tls_cert, "--tls-cert"));
      MVBRDF_ASSIGN_OR_RETURN(ssl.pem_private_key, ReadPem(connection.tls_key, "--tls-key"));
    }
    credentials = grpc::SslCredentials(ssl);
    if (!connection.tls_server_name.empty()) args.SetSslTargetNameOverride(connection.tls_server_name);
  }
  MVBRDF_ASSIGN_OR_RETURN(const std::string token, ResolveToken(connection));
  if (token.empty()) return grpc::CreateCustomChannel(address, credentials, args);
  std::vector<std::unique_ptr<grpc::experimental::ClientInterceptorFactoryInterface>> interceptors;
  interceptors.push_back(std::make_unique<BearerInterceptorFactory>(token));
  return grpc::experimental::CreateCustomChannelWithInterceptors(address, credentials, args, std::move(interceptors));
}

void QuietGrpcLog() {
  if (std::getenv("GRPC_VERBOSITY") != nullptr || std::getenv("GRPC_TRACE") != nullptr) return;
  gpr_set_log_function([](gpr_log_func_args* /*args*/) {});
}

}  // namespace mvbrdf::client
