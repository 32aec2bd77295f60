// libFuzzer target: the in-process plain-OBJ reader (core/scene/obj_reader.h),
// differentially against assimp. The input is an OBJ text. Whatever the
// reader calls plain must read through assimp's OBJ importer to the same
// corner positions, bit for bit (NaN compared by bits), in the same order;
// otherwise it must say nullopt, never crash or read out of bounds. Assimp
// runs in this process (no child: thousands of inputs per second), and only
// on inputs the reader calls plain, i.e. well-formed triangle OBJ files.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string_view>

#include "core/scene/mesh_loader.h"
#include "core/scene/obj_reader.h"
#include "tests/fuzz/fuzz_util.h"

namespace {

using mvbrdf::fuzz::Require;

bool SameBits(const glm::vec3& a, const glm::vec3& b) { return std::memcmp(&a, &b, sizeof(a)) == 0; }

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const std::optional<std::vector<glm::vec3>> plain = mvbrdf::scene::ReadPlainObjCorners(text);
  if (!plain.has_value()) return 0;
  Require(!plain->empty() && plain->size() % 3 == 0, "obj_reader_fuzz: corners are not whole triangles");
  const std::filesystem::path file = mvbrdf::fuzz::ScratchDir() / "input.obj";
  mvbrdf::fuzz::WriteBytes(file, data, size);
  const absl::StatusOr<std::vector<glm::vec3>> assimp = mvbrdf::scene::ImportCornerPositionsHereForTesting(file);
  mvbrdf::fuzz::Trace("assimp", assimp.status());
  Require(assimp.ok(), "obj_reader_fuzz: a plain file assimp cannot read");
  Require(assimp->size() == plain->size(), "obj_reader_fuzz: assimp reads another number of corners");
  for (size_t i = 0; i < plain->size(); ++i) {
    Require(SameBits((*plain)[i], (*assimp)[i]), "obj_reader_fuzz: assimp reads another position");
  }
  return 0;
}
