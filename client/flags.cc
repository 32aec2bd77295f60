#include "client/flags.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "absl/strings/str_cat.h"
#include "core/scene/names.h"

namespace mvbrdf::client {
namespace {

absl::Status Expected(const std::string& flag, const char* what, const std::string& got) {
  return absl::InvalidArgumentError(absl::StrCat(flag, ": expected ", what, ", got \"", scene::ShownName(got), "\""));
}

}  // namespace

void FlagParser::Add(const std::string& name_and_placeholder, const char* type_placeholder, std::string help,
                     std::string default_text, bool is_bool,
                     std::function<absl::Status(const std::string&, const std::string&)> set) {
  const size_t space = name_and_placeholder.find(' ');
  Flag flag;
  flag.name = name_and_placeholder.substr(0, space);
  if (!is_bool) {
    flag.placeholder = space == std::string::npos ? type_placeholder : name_and_placeholder.substr(space + 1);
  }
  flag.help = std::move(help);
  flag.default_text = std::move(default_text);
  flag.is_bool = is_bool;
  flag.set = [name = flag.name, set = std::move(set)](const std::string& v) { return set(name, v); };
  flags_.push_back(std::move(flag));
}

void FlagParser::AddString(const std::string& name, std::string* value, const std::string& help) {
  Add(name, "TEXT", help, *value, false, [value](const std::string&, const std::string& v) {
    *value = v;
    return absl::OkStatus();
  });
}

void FlagParser::AddInt(const std::string& name, int* value, const std::string& help) {
  Add(name, "N", help, std::to_string(*value), false, [value](const std::string& flag, const std::string& v) {
    char* end = nullptr;
    errno = 0;
    const long x = std::strtol(v.c_str(), &end, 10);
    if (v.empty() || *end != '\0' || errno != 0 || x < std::numeric_limits<int>::min() ||
        x > std::numeric_limits<int>::max()) {
      return Expected(flag, "an integer", v);
    }
    *value = static_cast<int>(x);
    return absl::OkStatus();
  });
}

void FlagParser::AddUint(const std::string& name, uint32_t* value, const std::string& help) {
  Add(name, "N", help, std::to_string(*value), false, [value](const std::string& flag, const std::string& v) {
    char* end = nullptr;
    errno = 0;
    const unsigned long long x = std::strtoull(v.c_str(), &end, 10);
    if (v.empty() || v[0] == '-' || *end != '\0' || errno != 0 || x > std::numeric_limits<uint32_t>::max()) {
      return Expected(flag, "a non-negative integer", v);
    }
    *value = static_cast<uint32_t>(x);
    return absl::OkStatus();
  });
}

void FlagParser::AddDouble(const std::string& name, double* value, const std::string& help) {
  std::string def = std::to_string(*value);
  def.erase(def.find_last_not_of('0') + 1);
  if (!def.empty() && def.back() == '.') def.pop_back();
  Add(name, "X", help, def, false, [value](const std::string& flag, const std::string& v) {
    char* end = nullptr;
    errno = 0;
    const double x = std::strtod(v.c_str(), &end);
    if (v.empty() || *end != '\0' || errno != 0 || !std::isfinite(x)) return Expected(flag, "a finite number", v);
    *value = x;
    return absl::OkStatus();
  });
}

void FlagParser::AddBool(const std::string& name, bool* value, const std::string& help) {
  Add(name, "", help, *value ? "true" : "false", true, [value](const std::string& flag, const std::string& v) {
    if (v == "true" || v == "1" || v.empty()) {
      *value = true;
    } else if (v == "false" || v == "0") {
      *value = false;
    } else {
      return Expected(flag, "true or false", v);
    }
    return absl::OkStatus();
  });
}

void FlagParser::AddPositional(const std::string& name, std::string* value, bool required, const std::string& help) {
  positionals_.push_back({name, value, required, help});
}

absl::Status FlagParser::Parse(const std::vector<std::string>& args) {
  size_t next_positional = 0;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "--help" || arg == "-h") {
      help_requested_ = true;
      return absl::OkStatus();
    }
    if (arg.size() > 2 && arg.compare(0, 2, "--") == 0) {
      const size_t eq = arg.find('=');
      const std::string name = arg.substr(0, eq);
      const Flag* flag = nullptr;
      for (const Flag& f : flags_) {
        if (f.name == name) flag = &f;
      }
      if (flag == nullptr) {
        std::vector<std::string> names;
        for (const Flag& f : flags_) names.push_back(f.name);
        const std::string closest = scene::ClosestName(name, names);
        return absl::InvalidArgumentError(
            absl::StrCat(scene::ShownName(name), ": unknown option for 'mvbrdf ", command_, "'",
                         closest.empty() ? "" : absl::StrCat("; did you mean ", closest, "?"), " (see 'mvbrdf ",
                         command_, " --help')"));
      }
      std::string value;
      if (eq != std::string::npos) {
        value = arg.substr(eq + 1);
      } else if (!flag->is_bool) {
        if (i + 1 >= args.size()) return absl::InvalidArgumentError(absl::StrCat(name, ": expected a value"));
        value = args[++i];
      }
      absl::Status s = flag->set(value);
      if (!s.ok()) return s;
      continue;
    }
    if (next_positional >= positionals_.size()) {
      return absl::InvalidArgumentError(
          absl::StrCat("unexpected argument \"", scene::ShownName(arg), "\" for 'mvbrdf ", command_, "'"));
    }
    *positionals_[next_positional++].value = arg;
  }
  for (size_t p = next_positional; p < positionals_.size(); ++p) {
    if (positionals_[p].required) {
      return absl::InvalidArgumentError(absl::StrCat(positionals_[p].name, ": required (see 'mvbrdf ", command_,
                                                     " --help')"));
    }
  }
  return absl::OkStatus();
}

std::string FlagParser::Usage() const {
  std::string out = absl::StrCat("usage: mvbrdf ", command_);
  for (const Positional& p : positionals_) absl::StrAppend(&out, p.required ? " " : " [", p.name, p.required ? "" : "]");
  if (!flags_.empty()) absl::StrAppend(&out, " [options]");
  absl::StrAppend(&out, "\n\n", synopsis_, "\n");
  for (const Positional& p : positionals_) absl::StrAppend(&out, "\n  ", p.name, "\n      ", p.help);
  for (const Flag& f : flags_) {
    absl::StrAppend(&out, "\n  ", f.name, f.is_bool ? "" : " ", f.placeholder, "\n      ", f.help);
    if (!f.default_text.empty()) absl::StrAppend(&out, " (default: ", f.default_text, ")");
  }
  absl::StrAppend(&out, "\n\nterms: docs/glossary.md\n");
  return out;
}

}  // namespace mvbrdf::client
