#include "core/base/proto_json.h"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/util/json_util.h>

#include <set>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf {
namespace {

// Protobuf's JSON parser takes the last of two equal keys ({"fx": 1, "fx": 2}
// is fx = 2), so a pasted-in second block silently wins. One pass over a
// document protobuf has already accepted (so it is well-formed): per object
// the keys seen, and the path to it for the error ("cameras[1].intrinsics").
// Keys compare as written (an escaped spelling of a key is not caught).
absl::Status CheckNoDuplicateKeys(absl::string_view json, absl::string_view origin) {
  struct Level {
    bool object;
    std::string name;  // how the path names this level
    std::set<std::string> keys;
    int index = 0;  // arrays: the element being read
  };
  std::vector<Level> stack;
  std::string pending_key;  // an object's key, once its ':' is read
  bool expect_key = false;
  auto path = [&]() {
    std::string out;
    for (const Level& l : stack) absl::StrAppend(&out, l.name);
    return out.empty() ? std::string("the top level") : out;
  };
  // The name the next value opened here gets in the path.
  auto child_name = [&]() -> std::string {
    if (stack.empty()) return "";
    if (stack.back().object) return absl::StrCat(stack.size() > 1 ? "." : "", pending_key);
    return absl::StrCat("[", stack.back().index, "]");
  };
  for (size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (c == '"') {
      size_t j = i + 1;
      while (j < json.size() && json[j] != '"') j += json[j] == '\\' ? 2 : 1;
      if (expect_key) {
        std::string key(json.substr(i + 1, j - i - 1));
        if (!stack.back().keys.insert(key).second) {
          return absl::InvalidArgumentError(
              absl::StrCat(origin, ": duplicate key \"", key, "\" in ", path(), " (JSON objects take each key once)"));
        }
        pending_key = std::move(key);
        expect_key = false;
      }
      i = j;
    } else if (c == '{' || c == '[') {
      const std::string name = child_name();
      stack.push_back({c == '{', name, {}, 0});
      expect_key = c == '{';
    } else if (c == '}' || c == ']') {
      if (!stack.empty()) stack.pop_back();
      expect_key = false;
    } else if (c == ',') {
      if (!stack.empty() && stack.back().object) {
        expect_key = true;
      } else if (!stack.empty()) {
        ++stack.back().index;
      }
    }
  }
  return absl::OkStatus();
}

// Protobuf's JSON mapping prints 64-bit integers as strings ("texelsSeen":
// "5891") for JavaScript's sake; a count should read as a number. One walk
// over the printed document (well-formed, produced from `descriptor`) beside
// the message's descriptor: a quoted value of an int64, uint64, sint64,
// fixed64 or sfixed64 field (also a repeated element, a map value and the
// Int64Value / UInt64Value wrappers) loses its quotes. Keys, string fields and
// every other value are copied as printed.
class Unquoter {
 public:
  explicit Unquoter(absl::string_view json) : j_(json) {}

  std::string Run(const google::protobuf::Descriptor* descriptor) {
    size_t i = Ws(0);
    if (i < j_.size() && j_[i] == '{') Object(descriptor, i);
    std::string out;
    out.reserve(j_.size());
    size_t from = 0;
    for (size_t q : drop_) {
      out.append(j_.data() + from, q - from);
      from = q + 1;
    }
    out.append(j_.data() + from, j_.size() - from);
    return out;
  }

 private:
  static bool Is64(const google::protobuf::FieldDescriptor* f) {
    using FD = google::protobuf::FieldDescriptor;
    return f->cpp_type() == FD::CPPTYPE_INT64 || f->cpp_type() == FD::CPPTYPE_UINT64;
  }
  static bool Is64Wrapper(const google::protobuf::Descriptor* d) {
    return d->full_name() == "google.protobuf.Int64Value" || d->full_name() == "google.protobuf.UInt64Value";
  }
  static bool WellKnown(const google::protobuf::Descriptor* d) {
    return d->file()->name().rfind("google/protobuf/", 0) == 0;
  }

  size_t Ws(size_t i) const {
    while (i < j_.size() && (j_[i] == ' ' || j_[i] == '\n' || j_[i] == '\r' || j_[i] == '\t')) ++i;
    return i;
  }
  // `i` at the opening quote; returns the index after the closing one.
  size_t String(size_t i) const {
    size_t k = i + 1;
    while (k < j_.size() && j_[k] != '"') k += j_[k] == '\\' ? 2 : 1;
    return k + 1;
  }
  // Any value, unchanged.
  size_t Skip(size_t i) const {
    if (i >= j_.size()) return i;
    if (j_[i] == '"') return String(i);
    if (j_[i] == '{' || j_[i] == '[') {
      int depth = 0;
      for (size_t k = i; k < j_.size(); ++k) {
        if (j_[k] == '"') {
          k = String(k) - 1;
        } else if (j_[k] == '{' || j_[k] == '[') {
          ++depth;
        } else if ((j_[k] == '}' || j_[k] == ']') && --depth == 0) {
          return k + 1;
        }
      }
      return j_.size();
    }
    size_t k = i;
    while (k < j_.size() && j_[k] != ',' && j_[k] != '}' && j_[k] != ']' && j_[k] != ' ' && j_[k] != '\n') ++k;
    return k;
  }
  // A quoted integer loses its quotes.
  size_t Quoted64(size_t i) {
    const size_t end = String(i);
    const absl::string_view body = j_.substr(i + 1, end - i - 2);
    const bool integer = !body.empty() && body.find_first_not_of("-0123456789") == absl::string_view::npos;
    if (!integer) return end;
    drop_.push_back(i);
    drop_.push_back(end - 1);
    return end;
  }
  // One value of `field` (an element when `element`).
  size_t Value(const google::protobuf::FieldDescriptor* field, size_t i, bool element) {
    if (field == nullptr || i >= j_.size()) return Skip(i);
    if (!element && field->is_map() && j_[i] == '{') {
      const google::protobuf::FieldDescriptor* value = field->message_type()->FindFieldByNumber(2);
      return Members(i, [&](absl::string_view, size_t v) { return Value(value, v, true); });
    }
    if (!element && field->is_repeated() && j_[i] == '[') {
      size_t k = Ws(i + 1);
      while (k < j_.size() && j_[k] != ']') {
        k = Ws(Value(field, k, true));
        if (k < j_.size() && j_[k] == ',') k = Ws(k + 1);
      }
      return k + 1;
    }
    if (j_[i] == '"' && (Is64(field) || (field->message_type() != nullptr && Is64Wrapper(field->message_type())))) {
      return Quoted64(i);
    }
    if (j_[i] == '{' && field->message_type() != nullptr && !WellKnown(field->message_type())) {
      return Object(field->message_type(), i);
    }
    return Skip(i);
  }
  size_t Object(const google::protobuf::Descriptor* d, size_t i) {
    return Members(i, [&](absl::string_view key, size_t v) {
      const google::protobuf::FieldDescriptor* field = nullptr;
      for (int f = 0; f < d->field_count() && field == nullptr; ++f) {
        if (d->field(f)->json_name() == key) field = d->field(f);
      }
      return Value(field, v, false);
    });
  }
  // `i` at '{': calls visit(key, index of its value) per member, which returns
  // the index after the value; returns the index after '}'.
  template <typename Visit>
  size_t Members(size_t i, Visit visit) {
    size_t k = Ws(i + 1);
    while (k < j_.size() && j_[k] == '"') {
      const size_t key_end = String(k);
      const absl::string_view key = j_.substr(k + 1, key_end - k - 2);
      k = Ws(key_end);
      if (k < j_.size() && j_[k] == ':') k = Ws(k + 1);
      k = Ws(visit(key, k));
      if (k < j_.size() && j_[k] == ',') k = Ws(k + 1);
    }
    return k + 1;
  }

  absl::string_view j_;
  std::vector<size_t> drop_;  // quotes to leave out, ascending
};

std::string Print(const google::protobuf::Message& message, bool whitespace, bool defaults) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = whitespace;
  options.preserve_proto_field_names = false;
  options.always_print_primitive_fields = defaults;
  std::string out;
  // Serialising a valid in-memory message cannot fail.
  (void)google::protobuf::util::MessageToJsonString(message, &out, options);
  return Unquoter(out).Run(message.GetDescriptor());
}

}  // namespace

absl::Status JsonToMessage(absl::string_view json, absl::string_view origin, google::protobuf::Message* message) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(std::string(json), message, options);
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(origin, ": not a valid ", message->GetDescriptor()->full_name(),
                                                   " JSON document: ", status.message().as_string()));
  }
  return CheckNoDuplicateKeys(json, origin);
}

std::string MessageToJson(const google::protobuf::Message& message) { return Print(message, true, false); }

std::string MessageToJsonWithDefaults(const google::protobuf::Message& message) { return Print(message, true, true); }

std::string MessageToOneLineJson(const google::protobuf::Message& message) { return Print(message, false, false); }

absl::Status ReadJsonFile(const std::filesystem::path& path, google::protobuf::Message* message) {
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(path));
  return JsonToMessage(text, path.string(), message);
}

absl::Status WriteJsonFile(const std::filesystem::path& path, const google::protobuf::Message& message) {
  return WriteStringToFile(path, MessageToJson(message));
}

}  // namespace mvbrdf
