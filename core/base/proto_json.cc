#include "core/base/proto_json.h"

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

std::string MessageToJson(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = false;
  std::string out;
  // Serialising a valid in-memory message cannot fail.
  (void)google::protobuf::util::MessageToJsonString(message, &out, options);
  return out;
}

std::string MessageToJsonWithDefaults(const google::protobuf::Message& message) {
  google::protobuf::util::JsonPrintOptions options;
  options.add_whitespace = true;
  options.preserve_proto_field_names = false;
  options.always_print_primitive_fields = true;
  std::string out;
  (void)google::protobuf::util::MessageToJsonString(message, &out, options);
  return out;
}

absl::Status ReadJsonFile(const std::filesystem::path& path, google::protobuf::Message* message) {
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(path));
  return JsonToMessage(text, path.string(), message);
}

absl::Status WriteJsonFile(const std::filesystem::path& path, const google::protobuf::Message& message) {
  return WriteStringToFile(path, MessageToJson(message));
}

}  // namespace mvbrdf
