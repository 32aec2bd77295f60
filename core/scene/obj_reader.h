// An in-process reader for plain Wavefront OBJ files: the later frames of a
// tracked mesh, read without starting assimp's child process.
//
// Assimp reads every mesh in a forked child (mesh_loader.cc), as it crashes
// and hangs on some malformed files. For a sequence of OBJ frames that cost
// was most of the frames' reading: bench-e2e's actor (12 k vertices, 0.9 MB
// per frame) took ~45-120 ms per frame, the fork in proportion to the
// process's memory. This reader takes a few milliseconds and is written for
// hostile input: one bounded pass over the text, no recursion, every index
// checked. It reads only what it is sure to read as assimp does, bit for bit
// (its numbers go through assimp's own parser, Assimp::fast_atof), and says
// so by returning nullopt for anything else, which then goes to assimp.
#ifndef MVBRDF_CORE_SCENE_OBJ_READER_H_
#define MVBRDF_CORE_SCENE_OBJ_READER_H_

#include <cstddef>
#include <optional>
#include <string_view>
#include <vector>

#include <glm/vec3.hpp>

namespace mvbrdf::scene {

// Texts longer than this are left to assimp (its child has a memory limit).
inline constexpr size_t kMaxPlainObjBytes = size_t{256} << 20;

// The positions of the triangles' corners of an OBJ text, three per triangle
// in file order: what assimp's OBJ importer gives, when the text is plain:
//   - `v X Y Z`, `vt U V [W]`, `vn X Y Z`, where every number is an optional
//     sign, digits, optionally a point and digits, optionally an exponent;
//   - `f A B C`, each corner P, P/T, P/T/N or P//N with 1-based indices within
//     the file's v, vt and vn lines (at most 9 digits, no leading zero);
//   - comments (`#` first on a line), blank lines, `s` and `mtllib` lines, and
//     `o`, `g` and `usemtl` lines before the first face;
//   - lines ended by \n or \r\n.
// Anything else gives nullopt: polygons, lines and points, negative
// (relative) indices, a `v` with a w or colours, a group, object or material
// after a face, line continuations, a byte 0, a line that starts with a blank,
// numbers written otherwise (".5", "nan"), a token of more than 64 bytes, no
// triangles, a text longer than kMaxPlainObjBytes, or a number assimp's
// parser refuses. `max_corners`: more than that many corners, or `v` lines,
// give nullopt as soon as they are read (a caller that knows how many to
// expect bounds the memory a hostile file takes to ~the text's size).
std::optional<std::vector<glm::vec3>> ReadPlainObjCorners(std::string_view text,
                                                          size_t max_corners = static_cast<size_t>(-1));

}  // namespace mvbrdf::scene

#endif  // MVBRDF_CORE_SCENE_OBJ_READER_H_
