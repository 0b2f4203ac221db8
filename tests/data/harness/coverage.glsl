// Coverage fixture: each counted line ends in a marker comment the test looks up.
#ifndef COVERAGE_FIXTURE_GLSL
#define COVERAGE_FIXTURE_GLSL

int never_called(int x) {  // @never-decl
  return x * 3;            // @never-body
}

float sample_twice(sampler2DShadow s, vec3 p, mat3x4 m[2]) {  // @sample-decl
  return texture(s, p) + m[1][0].x;                             // @sample-body
}

int classify(float x) {  // @classify-decl
  if (x < 0.0) {         // @if
    return -1;           // @negative
  }
  int n = 0;                    // @after-if
  for (int i = 0; i < 3; ++i) { // @loop
    n += 1;                     // @loop-body
  }
  return n;  // @return
}

#endif
