// One triangle covering the viewport, for the per-texel passes over the atlas
// of core/resample/resampler.cc (no vertex buffer: positions from gl_VertexID).

void main() {
  vec2 corner = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);  // (0,0), (2,0), (0,2)
  gl_Position = vec4(2.0 * corner - 1.0, 0.0, 1.0);
}
