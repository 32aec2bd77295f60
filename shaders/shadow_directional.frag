// Directional-light shadow map: the orthographic window depth is already
// linear in the distance along the light direction; nothing to write.

void main() {}
