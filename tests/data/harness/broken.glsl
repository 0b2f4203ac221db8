// A library file with a compile error on line 5.
float fine(float x) { return x; }

float broken(float x) {
  return x +* 2.0;
}
