#version 460
// The fetch-only kernel of penumbra-texel-rate: the device's texel-rate floor for the shadow
// filters. One invocation per screen pixel does taps_per_axis^2 fetches from a depth map around
// the pixel's own texel, sums them and stores the sum, and does nothing else. Screen-coherent,
// as a resolve's shadow coordinates are.
//   mode 0: compare taps of a 2D array map through a linear compare sampler, on a grid two
//           texels apart (the box-grid PCF's bilinear taps; also hard, Poisson, the PCSS filter);
//   mode 1: texelFetch of the raw depth, one texel apart (the PCSS blocker search);
//   mode 2: compare taps of a cube-map array, one texel apart in the plane perpendicular to the
//           direction (pcf_cube_array's pattern); the screen wraps once around the cube's sides.
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2DArrayShadow compare_map;
layout(set = 0, binding = 1) uniform sampler2DArray depth_map;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D result;
layout(set = 0, binding = 3) uniform samplerCubeArrayShadow cube_map;

layout(push_constant) uniform Params {
  ivec2 size;              // the screen, pixels
  int taps_per_axis;       // n: n * n fetches per pixel
  int mode;                // 0 compare, 1 texelFetch, 2 cube compare
  float texels_per_pixel;  // shadow texels per screen pixel along each axis (modes 0 and 1)
} params;

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(px, params.size))) return;
  int n = params.taps_per_axis;
  float sum = 0.0;
  if (params.mode == 2) {
    const float kPi = 3.14159265;
    vec2 f = (vec2(px) + 0.5) / vec2(params.size);
    float yaw = f.x * 2.0 * kPi;
    float pitch = (f.y - 0.5) * 0.5 * kPi;
    vec3 dir = vec3(cos(pitch) * cos(yaw), sin(pitch), cos(pitch) * sin(yaw));
    vec3 t = normalize(cross(abs(dir.y) < 0.9 ? vec3(0, 1, 0) : vec3(1, 0, 0), dir));
    vec3 b = cross(dir, t);
    float step = 2.0 / float(textureSize(cube_map, 0).x);
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        sum += texture(cube_map, vec4(dir + (float(i - n / 2) * t + float(j - n / 2) * b) * step, 0.0),
                       0.5);
  } else {
    ivec2 map_size = textureSize(depth_map, 0).xy;
    vec2 texel = 1.0 / vec2(map_size);
    vec2 centre = (vec2(px) + 0.5) * params.texels_per_pixel + 0.25;  // texel units, off-centre
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        if (params.mode == 0) {
          vec2 t = centre + vec2(2 * i - n + 1, 2 * j - n + 1);
          sum += texture(compare_map, vec4(t * texel, 0.0, 0.5));
        } else {
          ivec2 c = clamp(ivec2(centre) + ivec2(i - n / 2, j - n / 2), ivec2(0), map_size - 1);
          sum += texelFetch(depth_map, ivec3(c, 0), 0).r;
        }
      }
    }
  }
  imageStore(result, px, vec4(sum));
}
