#version 460
layout(location = 0) in vec3 position;
layout(location = 0) out vec3 world_position;

void main() {
  world_position = position;
  gl_Position = vec4(position, 1.0);
}
