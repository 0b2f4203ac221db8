#version 460
// The fetch-only kernel of penumbra-texel-rate: the device's texel-rate floor for the shadow
// filters. One invocation per screen pixel does taps_per_axis^2 fetches from a depth map on a
// grid two texels apart around the pixel's own texel (the pattern of the box-grid PCF: bilinear
// compare taps on neighbouring texel pairs; screen-coherent, as a resolve's shadow coordinates
// are), sums them and stores the sum, and does nothing else. mode 0: compare taps through a
// linear compare sampler (hard, PCF, Poisson and the PCSS filter); mode 1: texelFetch of the raw
// depth (the PCSS blocker search).
layout(local_size_x = 8, local_size_y = 8) in;

layout(set = 0, binding = 0) uniform sampler2DArrayShadow compare_map;
layout(set = 0, binding = 1) uniform sampler2DArray depth_map;
layout(set = 0, binding = 2, r32f) uniform writeonly image2D result;

layout(push_constant) uniform Params {
  ivec2 size;            // the screen, pixels
  int taps_per_axis;     // n: n * n fetches per pixel
  int mode;              // 0 compare, 1 texelFetch
  float texels_per_pixel;  // shadow texels per screen pixel along each axis
} params;

void main() {
  ivec2 px = ivec2(gl_GlobalInvocationID.xy);
  if (any(greaterThanEqual(px, params.size))) return;
  ivec2 map_size = textureSize(depth_map, 0).xy;
  vec2 texel = 1.0 / vec2(map_size);
  vec2 centre = (vec2(px) + 0.5) * params.texels_per_pixel + 0.25;  // texel units, off-centre
  int n = params.taps_per_axis;
  float sum = 0.0;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      vec2 t = centre + vec2(2 * i - n + 1, 2 * j - n + 1);
      if (params.mode == 0) {
        sum += texture(compare_map, vec4(t * texel, 0.0, 0.5));
      } else {
        ivec2 c = clamp(ivec2(t), ivec2(0), map_size - 1);
        sum += texelFetch(depth_map, ivec3(c, 0), 0).r;
      }
    }
  }
  imageStore(result, px, vec4(sum));
}
