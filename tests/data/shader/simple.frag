#version 460
layout(location = 0) in vec3 world_position;
layout(location = 0) out vec4 color;

void main() {
  color = vec4(fract(world_position), 1.0);
}
