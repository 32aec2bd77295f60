// Triangle-id pass of core/render/phong_renderer.cc (RenderTriangleIds): the
// index of the visible triangle. The index buffer holds the triangles in
// RenderMesh order and one draw covers them all, so gl_PrimitiveID is the
// index into RenderMesh::triangles. The target is R32I, cleared to -1.

layout(location = 0) out int out_triangle;

void main() { out_triangle = gl_PrimitiveID; }
