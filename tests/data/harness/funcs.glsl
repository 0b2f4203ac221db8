// Functions the harness self-tests call. Each one exercises a layout or calling-convention case.
#ifndef HARNESS_FUNCS_GLSL
#define HARNESS_FUNCS_GLSL

struct Light {
  vec3 dir;
  float intensity;
};

struct Pair {
  float a;
  vec3 b;  // vec3 after a float: offset 16 in std430
  bool flag;
};

// Twenty fields of mixed types (a real library's material struct has 19).
struct Wide {
  float f0; vec3 v1; int i2; bool b3; vec2 w4; float f5; vec4 q6; uint u7; float f8; vec3 v9;
  float f10; int i11; vec2 w12; float f13; bool b14; vec3 v15; float f16; uint u17; vec4 q18;
  float f19;
};

// Each field moved by d (numbers), flipped (bools) or incremented (integers).
Wide wide_shift(Wide w, float d) {
  w.f0 += d; w.v1 += d; w.i2 += 1; w.b3 = !w.b3; w.w4 += d; w.f5 += d; w.q6 += d; w.u7 += 1u;
  w.f8 += d; w.v9 += d; w.f10 += d; w.i11 += 1; w.w12 += d; w.f13 += d; w.b14 = !w.b14;
  w.v15 += d; w.f16 += d; w.u17 += 1u; w.q18 += d; w.f19 += d;
  return w;
}

// A function-like macro, and a function over a macro type: the wrapper calls them as written.
#define TWICE(x) ((x) * 2.0)
#define REAL float
REAL halve(REAL x) { return x * 0.5; }

float add_mul(float a, float b, float c) { return a + b * c; }

// A float then a vec3: the vec3 sits at offset 16 of the case struct.
vec3 scale_vec3(float s, vec3 v) { return s * v; }

mat3 transpose3(mat3 m) { return transpose(m); }
mat2 inverse2(mat2 m) { return inverse(m); }
mat4 mul4(mat4 a, mat4 b) { return a * b; }
mat4x3 drop_row(mat4 m) { return mat4x3(m); }

bool is_positive(float x) { return x > 0.0; }
bvec3 signs(vec3 v) { return greaterThan(v, vec3(0.0)); }

int floor_to_int(float x) { return int(floor(x)); }
uvec2 hash2(uvec2 v) { return v * 1664525u + 1013904223u; }
ivec4 negate4(ivec4 v) { return -v; }

void split(vec4 v, out vec2 lo, out vec2 hi) {
  lo = v.xy;
  hi = v.zw;
}

// Returns the old accumulator; the inout parameter comes back with the sum.
float accumulate(inout float acc, float x) {
  float old = acc;
  acc += x;
  return old;
}

float light_dot(Light l, vec3 n) { return max(dot(normalize(l.dir), n), 0.0) * l.intensity; }

Pair make_pair(float a, vec3 b) { return Pair(a, b, a > b.x); }

float sum4(float v[4]) { return v[0] + v[1] + v[2] + v[3]; }
vec3 sum_vec3s(vec3 v[3]) { return v[0] + v[1] + v[2]; }
float total_intensity(Light ls[3]) { return ls[0].intensity + ls[1].intensity + ls[2].intensity; }

void reverse3(inout float v[3]) {
  float t = v[0];
  v[0] = v[2];
  v[2] = t;
}

#ifndef HARNESS_SCALE
#define HARNESS_SCALE 1.0
#endif
layout(constant_id = 7) const float kSpecScale = 1.0;
float scaled(float x) { return x * HARNESS_SCALE * kSpecScale; }

// One hardware compare tap.
float compare_tap(sampler2DShadow map, vec3 uv_ref) { return texture(map, uv_ref); }
float compare_tap_array(sampler2DArrayShadow map, vec4 uv_layer_ref) { return texture(map, uv_layer_ref); }
float raw_depth(sampler2D map, vec2 uv) { return textureLod(map, uv, 0.0).r; }
vec4 fetch_texel(sampler2D map, ivec2 p) { return texelFetch(map, p, 0); }
float cube_value(samplerCube cube, vec3 dir) { return textureLod(cube, dir, 0.0).r; }

// 3×3 PCF of bilinear compare taps, one texel apart.
float pcf3x3(sampler2DShadow map, vec2 uv, float ref, vec2 texel) {
  float sum = 0.0;
  for (int y = -1; y <= 1; ++y)
    for (int x = -1; x <= 1; ++x) sum += texture(map, vec3(uv + vec2(x, y) * texel, ref));
  return sum / 9.0;
}


// Storage images: written (every device) and read-modify-written (devices that can read a
// format-less image); the layer of an array is the coordinate's z.
uint store_texel(image2D img, ivec2 p, vec4 v) {
  imageStore(img, p, v);
  return uint(p.x + 1000 * p.y);
}
uint store_layer_texel(image2DArray img, ivec3 p, vec4 v) {
  imageStore(img, p, v);
  return uint(p.z);
}
vec4 add_to_texel(image2D img, ivec2 p, vec4 v) {
  vec4 old = imageLoad(img, p);
  imageStore(img, p, old + v);
  return old;
}

// Out-of-bounds probes: an array fetch with an offset, and a fetch at a chosen level.
vec4 fetch_layer_offset(sampler2DArray map, ivec3 p) { return texelFetchOffset(map, p, 0, ivec2(1, 0)); }
vec4 fetch_level(sampler2D map, ivec2 p, int level) { return texelFetch(map, p, level); }

// Code the macros must leave compiling: texelFetch of types no parameter here binds.
layout(set = 1, binding = 0) uniform usampler2D harness_ids;
layout(set = 1, binding = 1) uniform isamplerBuffer harness_list;
uint harness_id_at(ivec2 p) { return texelFetch(harness_ids, p, 0).r + uint(texelFetch(harness_list, p.x).r); }

// Debug printf: a case prints its input, and a second line when it is negative.
#extension GL_EXT_debug_printf : enable
float print_and_square(float x) {
  debugPrintfEXT("x = %f", x);
  if (x < 0.0) debugPrintfEXT("negative: %f", x);
  return x * x;
}


// Forty fields (a float, vec3, int, vec2 cycle: std430 pads each vec3 to 16), each moved by d.
struct Wide40 {
  float m0;
  vec3 m1;
  int m2;
  vec2 m3;
  float m4;
  vec3 m5;
  int m6;
  vec2 m7;
  float m8;
  vec3 m9;
  int m10;
  vec2 m11;
  float m12;
  vec3 m13;
  int m14;
  vec2 m15;
  float m16;
  vec3 m17;
  int m18;
  vec2 m19;
  float m20;
  vec3 m21;
  int m22;
  vec2 m23;
  float m24;
  vec3 m25;
  int m26;
  vec2 m27;
  float m28;
  vec3 m29;
  int m30;
  vec2 m31;
  float m32;
  vec3 m33;
  int m34;
  vec2 m35;
  float m36;
  vec3 m37;
  int m38;
  vec2 m39;
};
Wide40 wide40_shift(Wide40 w, float d) {
  w.m0 += d;
  w.m1 += d;
  w.m2 += 1;
  w.m3 += d;
  w.m4 += d;
  w.m5 += d;
  w.m6 += 1;
  w.m7 += d;
  w.m8 += d;
  w.m9 += d;
  w.m10 += 1;
  w.m11 += d;
  w.m12 += d;
  w.m13 += d;
  w.m14 += 1;
  w.m15 += d;
  w.m16 += d;
  w.m17 += d;
  w.m18 += 1;
  w.m19 += d;
  w.m20 += d;
  w.m21 += d;
  w.m22 += 1;
  w.m23 += d;
  w.m24 += d;
  w.m25 += d;
  w.m26 += 1;
  w.m27 += d;
  w.m28 += d;
  w.m29 += d;
  w.m30 += 1;
  w.m31 += d;
  w.m32 += d;
  w.m33 += d;
  w.m34 += 1;
  w.m35 += d;
  w.m36 += d;
  w.m37 += d;
  w.m38 += 1;
  w.m39 += d;
  return w;
}

#endif

// For the spec-interval tests: a contractible a * b + c, the same `precise`, a product, a
// quotient.
float mul_add(float a, float b, float c) { return a * b + c; }
float mul_add_precise(float a, float b, float c) {
  precise float r = a * b + c;
  return r;
}
float mul2(float a, float b) { return a * b; }
float div2(float a, float b) { return a / b; }
