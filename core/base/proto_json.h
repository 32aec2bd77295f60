// JSON I/O for any protobuf message through Protobuf's JSON mapping (no
// hand-written JSON parser anywhere in the project).
#ifndef MVBRDF_CORE_BASE_PROTO_JSON_H_
#define MVBRDF_CORE_BASE_PROTO_JSON_H_

#include <filesystem>
#include <string>
#include "absl/strings/string_view.h"

#include <google/protobuf/message.h>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace mvbrdf {

// Parses JSON into `message`. Unknown fields are an error (a typo in a field
// name must not be silently ignored), and so is a key given twice in one
// object ("duplicate key \"fx\" in cameras[0].intrinsics"). `origin` names
// the source in errors.
absl::Status JsonToMessage(absl::string_view json, absl::string_view origin, google::protobuf::Message* message);

// Pretty-printed JSON with lowerCamelCase names; fields at their default
// values are left out. Unlike Protobuf's mapping, 64-bit integer fields
// (int64, uint64, sint64, fixed64, sfixed64; also repeated elements, map
// values and the Int64Value/UInt64Value wrappers) are JSON numbers, not
// strings ("texelsSeen": 5891): every digit is written, so a value above 2^53
// is exact in the text and for readers with exact integers (Protobuf's own
// parser, Python), while a reader parsing numbers as doubles (JavaScript)
// rounds it to the nearest double.
std::string MessageToJson(const google::protobuf::Message& message);
// The same with every field printed, also at its default value (a result
// whose `false` or `0` is the answer, e.g. configurationCorrect).
std::string MessageToJsonWithDefaults(const google::protobuf::Message& message);
// One line, no whitespace (an event stream: one object per line).
std::string MessageToOneLineJson(const google::protobuf::Message& message);

absl::Status ReadJsonFile(const std::filesystem::path& path, google::protobuf::Message* message);
absl::Status WriteJsonFile(const std::filesystem::path& path, const google::protobuf::Message& message);

template <typename T>
absl::StatusOr<T> ReadJsonFileAs(const std::filesystem::path& path) {
  T message;
  absl::Status status = ReadJsonFile(path, &message);
  if (!status.ok()) return status;
  return message;
}

}  // namespace mvbrdf

#endif  // MVBRDF_CORE_BASE_PROTO_JSON_H_
