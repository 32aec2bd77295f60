// A small typed command-line parser for the `mvbrdf` subcommands:
// `--name value`, `--name=value`, boolean `--name`, positional arguments and
// `--help`. Each flag is bound to a typed variable that holds its default.
#ifndef MVBRDF_CLIENT_FLAGS_H_
#define MVBRDF_CLIENT_FLAGS_H_

#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace mvbrdf::client {

class FlagParser {
 public:
  FlagParser(std::string command, std::string synopsis) : command_(std::move(command)), synopsis_(std::move(synopsis)) {}

  // `name` is the flag, optionally followed by a space and the placeholder
  // its help shows for the value: "--atlas N", "--out DIR". Without one the
  // placeholder says the type: N (integers), X (numbers), TEXT (strings).
  void AddString(const std::string& name, std::string* value, const std::string& help);
  void AddInt(const std::string& name, int* value, const std::string& help);
  void AddUint(const std::string& name, uint32_t* value, const std::string& help);
  void AddDouble(const std::string& name, double* value, const std::string& help);
  void AddBool(const std::string& name, bool* value, const std::string& help);
  // Positional arguments, in order; `required` of them must be present.
  void AddPositional(const std::string& name, std::string* value, bool required, const std::string& help);

  // Parses args (without the program and subcommand names). Errors name the
  // flag: "--cameras: expected an integer, got \"x\"". Sets help_requested().
  absl::Status Parse(const std::vector<std::string>& args);
  bool help_requested() const { return help_requested_; }
  std::string Usage() const;

 private:
  struct Flag {
    std::string name;
    std::string placeholder;  // empty for booleans
    std::string help;
    std::string default_text;
    bool is_bool = false;
    std::function<absl::Status(const std::string&)> set;
  };
  struct Positional {
    std::string name;
    std::string* value;
    bool required;
    std::string help;
  };
  void Add(const std::string& name_and_placeholder, const char* type_placeholder, std::string help,
           std::string default_text, bool is_bool,
           std::function<absl::Status(const std::string&, const std::string&)> set);
  std::string command_;
  std::string synopsis_;
  std::vector<Flag> flags_;
  std::vector<Positional> positionals_;
  bool help_requested_ = false;
};

}  // namespace mvbrdf::client

#endif  // MVBRDF_CLIENT_FLAGS_H_
