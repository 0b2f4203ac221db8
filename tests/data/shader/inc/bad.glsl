// A deliberately broken helper.

float bad() {
  return 2.0 * missing_symbol;
}
