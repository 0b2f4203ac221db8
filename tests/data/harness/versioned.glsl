// A library as third-party GLSL ships it: its own #version first, no include guard.
#version 330 core
float versioned_twice(float x) { return 2.0 * x; }
