#include "core/base/proto_json.h"

#include <google/protobuf/util/json_util.h>

#include "absl/strings/str_cat.h"
#include "core/base/files.h"
#include "core/base/status_macros.h"

namespace mvbrdf {

absl::Status JsonToMessage(absl::string_view json, absl::string_view origin, google::protobuf::Message* message) {
  google::protobuf::util::JsonParseOptions options;
  options.ignore_unknown_fields = false;
  const auto status = google::protobuf::util::JsonStringToMessage(std::string(json), message, options);
  if (!status.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(origin, ": not a valid ", message->GetDescriptor()->full_name(),
                                                   " JSON document: ", status.message().as_string()));
  }
  return absl::OkStatus();
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

absl::Status ReadJsonFile(const std::filesystem::path& path, google::protobuf::Message* message) {
  MVBRDF_ASSIGN_OR_RETURN(const std::string text, ReadFileToString(path));
  return JsonToMessage(text, path.string(), message);
}

absl::Status WriteJsonFile(const std::filesystem::path& path, const google::protobuf::Message& message) {
  return WriteStringToFile(path, MessageToJson(message));
}

}  // namespace mvbrdf
