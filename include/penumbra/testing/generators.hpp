#pragma once

// Seeded case generation. A generator is a small value type with `T operator()(Rng&) const`;
// the same seed gives the same sequence on every platform (the distributions are written here,
// not taken from <random>, whose distributions differ between standard libraries).
//
//   Rng rng(42);
//   auto angle = uniform(0.0f, 6.2831853f);
//   auto dir = unit_vector3();
//   auto x = mix(extremes_float(), 0.25, uniform(-1.0f, 1.0f));
//   auto depth = depth_extremes(DepthConvention::reverse_z);
//   float a = angle(rng);

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
#include <initializer_list>
#include <penumbra/core/depth.hpp>
#include <penumbra/core/error.hpp>
#include <penumbra/testing/values.hpp>
#include <random>
#include <string>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

namespace penumbra::testing {

// The project's one depth convention type (reverse_z or standard).
using DepthConvention = penumbra::DepthConvention;

// The seed used when neither the test nor PENUMBRA_SEED picks one.
inline constexpr std::uint64_t kDefaultSeed = 12345;

class Rng {
 public:
  explicit Rng(std::uint64_t seed = kDefaultSeed) : seed_(seed), engine_(seed) {}

  std::uint64_t seed() const { return seed_; }
  void reseed(std::uint64_t seed) {
    seed_ = seed;
    engine_.seed(seed);
  }

  std::uint64_t next_u64() { return engine_(); }
  // Uniform in [0, 1), 53 random bits.
  double next_unit() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  // Uniform in [0, n), unbiased; n > 0.
  std::uint64_t below(std::uint64_t n);
  bool bernoulli(double p) { return next_unit() < p; }

  std::mt19937_64& engine() { return engine_; }

 private:
  std::uint64_t seed_;
  std::mt19937_64 engine_;
};

// The value type a generator produces.
template <class G>
using generator_result_t = std::remove_cvref_t<std::invoke_result_t<const G&, Rng&>>;

template <class G>
concept Generator = requires(const G& g, Rng& rng) {
  g(rng);
};

// ---------------------------------------------------------------------------------------------
// uniform

namespace detail {

float uniform_scalar(Rng& rng, float lo, float hi);
double uniform_scalar(Rng& rng, double lo, double hi);
std::int32_t uniform_scalar(Rng& rng, std::int32_t lo, std::int32_t hi);
std::uint32_t uniform_scalar(Rng& rng, std::uint32_t lo, std::uint32_t hi);
bool uniform_scalar(Rng& rng, bool lo, bool hi);

[[noreturn]] void throw_bad_range(const std::string& lo, const std::string& hi);

}  // namespace detail

// Uniform in the closed range [lo, hi]; vectors componentwise.
template <class T>
struct Uniform {
  T lo;
  T hi;
  T operator()(Rng& rng) const {
    if constexpr (detail::VecInfo<T>::value) {
      T v;
      for (glm::length_t c = 0; c < detail::VecInfo<T>::length; ++c) {
        v[c] = detail::uniform_scalar(rng, lo[c], hi[c]);
      }
      return v;
    } else {
      return detail::uniform_scalar(rng, lo, hi);
    }
  }
};

// uniform(-1.0f, 1.0f), uniform(0, 9), uniform(0u, 255u), uniform(glm::vec3(-1), glm::vec3(1)).
// Throws penumbra::Error when lo > hi (in any component) or a bound is not finite.
template <class T>
requires(detail::is_scalar_v<T> || detail::VecInfo<T>::value) Uniform<T> uniform(T lo, T hi) {
  const auto bad_pair = [](auto a, auto b) {
    if constexpr (std::is_floating_point_v<decltype(a)>) {
      if (!std::isfinite(a) || !std::isfinite(b)) return true;
    }
    return !(a <= b);
  };
  bool bad = false;
  if constexpr (detail::VecInfo<T>::value) {
    for (glm::length_t c = 0; c < detail::VecInfo<T>::length; ++c) {
      bad = bad || bad_pair(lo[c], hi[c]);
    }
  } else {
    bad = bad_pair(lo, hi);
  }
  if (bad) detail::throw_bad_range(format_value(lo), format_value(hi));
  return Uniform<T>{lo, hi};
}

// Every component in the same range: uniform<glm::vec3>(-1.0f, 1.0f).
template <class V>
requires detail::VecInfo<V>::value Uniform<V> uniform(typename detail::VecInfo<V>::Scalar lo,
                                                      typename detail::VecInfo<V>::Scalar hi) {
  return uniform(V(lo), V(hi));
}

// ---------------------------------------------------------------------------------------------
// Directions, choices, constants, combinators

// Uniformly distributed on the unit sphere (normalized in float).
struct UnitVector3 {
  glm::vec3 operator()(Rng& rng) const;
};
inline UnitVector3 unit_vector3() {
  return {};
}

template <class T>
struct OneOf {
  std::vector<T> values;
  T operator()(Rng& rng) const {
    return values[static_cast<std::size_t>(rng.below(values.size()))];
  }
};
// Picks one of the values uniformly. Throws penumbra::Error when empty.
template <class T>
OneOf<T> one_of(std::vector<T> values) {
  if (values.empty()) throw Error("one_of: the list of values is empty");
  return OneOf<T>{std::move(values)};
}
template <class T>
OneOf<T> one_of(std::initializer_list<T> values) {
  return one_of(std::vector<T>(values));
}

template <class T>
struct Constant {
  T value;
  T operator()(Rng&) const { return value; }
};
template <class T>
Constant<T> constant(T value) {
  return Constant<T>{std::move(value)};
}

// Draws from a with probability p, else from b.
template <class A, class B>
struct Mix {
  A a;
  double p;
  B b;
  using Result = std::common_type_t<generator_result_t<A>, generator_result_t<B>>;
  Result operator()(Rng& rng) const {
    if (rng.next_unit() < p) return a(rng);
    return b(rng);
  }
};
template <Generator A, Generator B>
Mix<std::decay_t<A>, std::decay_t<B>> mix(A&& a, double p, B&& b) {
  if (!(p >= 0.0 && p <= 1.0)) {
    throw Error("mix: probability " + std::to_string(p) + " is outside [0, 1]");
  }
  return {std::forward<A>(a), p, std::forward<B>(b)};
}

// f(value) of each drawn value: map(uniform(0.0f, 1.0f), [](float t) { return t * t; }).
template <class G, class F>
struct Map {
  G generator;
  F f;
  auto operator()(Rng& rng) const { return f(generator(rng)); }
};
template <Generator G, class F>
Map<std::decay_t<G>, std::decay_t<F>> map(G&& generator, F&& f) {
  return {std::forward<G>(generator), std::forward<F>(f)};
}

// A glm vector whose components are drawn independently: vec_of<3>(extremes_float()).
template <glm::length_t L, class G>
struct VecOf {
  G generator;
  glm::vec<L, generator_result_t<G>> operator()(Rng& rng) const {
    glm::vec<L, generator_result_t<G>> v;
    for (glm::length_t c = 0; c < L; ++c) v[c] = generator(rng);
    return v;
  }
};
template <glm::length_t L, Generator G>
VecOf<L, std::decay_t<G>> vec_of(G&& generator) {
  return {std::forward<G>(generator)};
}

// A glm vector with a generator per component, drawn in order:
// vec_from(uniform(0.0f, 1.0f), uniform(-1.0f, 1.0f), constant(0.0f)) gives a vec3 whose x is
// in [0, 1], y in [-1, 1] and z is 0. The generators must produce the same scalar type.
template <class... G>
struct VecFrom {
  std::tuple<G...> generators;
  using Scalar = std::common_type_t<generator_result_t<G>...>;
  glm::vec<sizeof...(G), Scalar> operator()(Rng& rng) const {
    glm::vec<sizeof...(G), Scalar> v;
    std::apply(
        [&](const auto&... g) {
          glm::length_t c = 0;
          ((v[c++] = g(rng)), ...);
        },
        generators);
    return v;
  }
};
template <Generator... G>
requires(
    sizeof...(G) >= 2 && sizeof...(G) <= 4 &&
    (std::is_same_v<generator_result_t<std::decay_t<G>>,
                    generator_result_t<std::decay_t<std::tuple_element_t<0, std::tuple<G...>>>>> &&
     ...)) VecFrom<std::decay_t<G>...> vec_from(G&&... generators) {
  return {std::tuple<std::decay_t<G>...>(std::forward<G>(generators)...)};
}

// A std::array whose elements are drawn independently.
template <std::size_t N, class G>
struct ArrayOf {
  G generator;
  std::array<generator_result_t<G>, N> operator()(Rng& rng) const {
    std::array<generator_result_t<G>, N> a{};
    for (auto& element : a) element = generator(rng);
    return a;
  }
};
template <std::size_t N, Generator G>
ArrayOf<N, std::decay_t<G>> array_of(G&& generator) {
  return {std::forward<G>(generator)};
}

// ---------------------------------------------------------------------------------------------
// Extremes

struct ExtremeOptions {
  bool nan_inf = false;           // NaN, +Inf and -Inf (for functions that must tolerate them)
  bool denormals = true;          // the smallest and largest denormals (of each sign)
  bool max_values = true;         // +-FLT_MAX
  bool negative = true;           // the negated specials, and negative ordinary values
  double special_fraction = 0.5;  // share of draws taken from the special values
  float lo = -100.0f;             // ordinary draws: uniform in [lo, hi] (lo >= 0 if !negative)
  float hi = 100.0f;
};

// The special values extremes_float draws from, without duplicates: +0, the smallest and the
// largest denormal, FLT_MIN, 1e-30, 0.5, nextafter(1, 0), 1, nextafter(1, 2), 1e30, FLT_MAX,
// each also negated (-0, ..., -1, ...), and NaN, +Inf, -Inf, as the options allow.
std::vector<float> extreme_float_values(const ExtremeOptions& options = {});

struct ExtremeFloat {
  std::vector<float> specials;
  ExtremeOptions options;
  float operator()(Rng& rng) const;
};
ExtremeFloat extremes_float(const ExtremeOptions& options = {});

struct DepthExtremeOptions {
  double special_fraction = 0.5;  // share of draws taken from the special depths
  bool out_of_range = false;      // also nextafter(0, -1), -1e-7, nextafter(1, 2), 1 + 1e-7
  // Ordinary draws: half uniform in [0, 1], half the depths of view distances log-uniform in
  // [near, far] under the convention's perspective mapping (most values near 0 for reverse_z,
  // near 1 for standard), where precision problems live.
  double near = 0.1;
  double far = 1000.0;
};

// 0, -0, 1, nextafter(1, 0), nextafter(0, 1), 1e-7, 1 - 1e-7, 0.5, the depths of the near and
// far planes nudged one float inward, and the out-of-range values when asked.
std::vector<float> depth_special_values(DepthConvention convention,
                                        const DepthExtremeOptions& options = {});

struct DepthExtremes {
  DepthConvention convention;
  std::vector<float> specials;
  DepthExtremeOptions options;
  float operator()(Rng& rng) const;
};
DepthExtremes depth_extremes(DepthConvention convention, const DepthExtremeOptions& options = {});

// ---------------------------------------------------------------------------------------------
// Cases

// n cases, each a tuple of one draw per generator (drawn left to right).
template <Generator... Gens>
std::vector<std::tuple<generator_result_t<Gens>...>> generate_cases(Rng& rng, std::size_t n,
                                                                    const Gens&... gens) {
  std::vector<std::tuple<generator_result_t<Gens>...>> cases;
  cases.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    // A braced list evaluates its elements in order, so the draws are deterministic.
    cases.push_back(std::tuple<generator_result_t<Gens>...>{gens(rng)...});
  }
  return cases;
}

}  // namespace penumbra::testing
