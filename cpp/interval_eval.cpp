// Interval dual numbers over boxes; see interval_eval.hpp.  Each rule has its
// twin of the same name in tests/interval_reference.py, the numpy reference
// the tests compare this evaluator against.
#include "interval_eval.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

#include "on_cores.hpp"

namespace rdmesh {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMax = DBL_MAX;
constexpr double kTiny = DBL_MIN;  // smallest normal
constexpr double kRel = kRelWidening;  // of libm results
const double kPi = std::acos(-1.0);
const double kPiUp = std::nextafter(kPi, kInf);  // above the true pi

struct I {
  double lo, hi;
};

// A float below x, one to two ulps (NaN gives -inf, +inf the largest float),
// and above.  In round-to-nearest, fl(x - fl(fl(2**-52 |x|) + 2**-1074)) is at
// most the float below x, as 2**-52 |x| is at least one ulp of x and 2**-1074
// the subnormal spacing.  No libm call (nextafter is one).
constexpr double kUlpRel = 2.220446049250313e-16;  // 2**-52
constexpr double kEta = 4.9406564584124654e-324;   // 2**-1074
// Comparisons rather than fmin/fmax: those are libm calls under CGAL's
// -frounding-math.
inline double dn(double x) {
  const double ax = std::fabs(x);
  const double r = x - ((ax < kMax ? ax : kMax) * kUlpRel + kEta);
  return r > kMax ? kMax : (r == r ? r : -kInf);  // NaN gives -inf
}
inline double up(double x) {
  const double ax = std::fabs(x);
  const double r = x + ((ax < kMax ? ax : kMax) * kUlpRel + kEta);
  return r < -kMax ? -kMax : (r == r ? r : kInf);
}
// Bounds for a libm result: widened relatively and absolutely, then rounded.
inline double dn_t(double x) {
  const double ax = std::fabs(x);
  return dn(x - ((ax < kMax ? ax : kMax) * kRel + kTiny));
}
inline double up_t(double x) {
  const double ax = std::fabs(x);
  return up(x + ((ax < kMax ? ax : kMax) * kRel + kTiny));
}

inline I point(double c) { return {c, c}; }
inline I full() { return {-kInf, kInf}; }
inline bool has0(I a) { return a.lo <= 0 && a.hi >= 0; }

// Knuth's TwoSum: sums whose rounding error is 0 are kept exact.
inline double add_dn(double u, double v) {
  const double s = u + v, vv = s - u;
  const double err = (u - (s - vv)) + (v - vv);
  return err >= 0 ? s : dn(s);
}
inline double add_up(double u, double v) {
  const double s = u + v, vv = s - u;
  const double err = (u - (s - vv)) + (v - vv);
  return err <= 0 ? s : up(s);
}
inline I add(I a, I b) { return {add_dn(a.lo, b.lo), add_up(a.hi, b.hi)}; }
inline I sub(I a, I b) { return {add_dn(a.lo, -b.hi), add_up(a.hi, -b.lo)}; }
inline I neg(I a) { return {-a.hi, -a.lo}; }

// +-2**k (normal): a product by it is exact unless it under- or overflows.
inline bool pow2(double u) {
  std::uint64_t bits;
  std::memcpy(&bits, &u, sizeof bits);
  const std::uint64_t expo = (bits >> 52) & 0x7ff;
  return (bits & 0xfffffffffffffULL) == 0 && expo != 0 && expo != 0x7ff;
}

inline I signed_(I r, I a, I b) {
  const bool nonneg = (a.lo >= 0 && b.lo >= 0) || (a.hi <= 0 && b.hi <= 0);
  const bool nonpos = (a.lo >= 0 && b.hi <= 0) || (a.hi <= 0 && b.lo >= 0);
  if (nonneg) r.lo = std::max(r.lo, 0.0);
  if (nonpos) r.hi = std::min(r.hi, 0.0);
  return r;
}

// One corner product.  exact: it needs no rounding (a zero factor makes the
// product exactly 0, also against an infinite bound; a product by +-2**k in
// the normal range is exact).
inline double corner(double u, double v, bool& exact) {
  if (u == 0 || v == 0) return 0.0;
  const double p = u * v;
  const double ap = std::fabs(p);
  exact = exact && (pow2(u) || pow2(v)) && ap >= kTiny && ap <= kMax;
  return p;
}

// The extreme products, rounded once: dn and up are monotone and move at least
// one ulp, so dn(min fl(u v)) is below the least true product.
inline I mul(I a, I b) {
  bool exact = true;
  double lo, hi;
  if (b.lo == b.hi || a.lo == a.hi) {  // a point factor (a constant, a unit gradient)
    if (a.lo == a.hi) std::swap(a, b);
    const double p1 = corner(a.lo, b.lo, exact), p2 = corner(a.hi, b.lo, exact);
    lo = std::min(p1, p2);
    hi = std::max(p1, p2);
  } else {
    const double p1 = corner(a.lo, b.lo, exact), p2 = corner(a.hi, b.lo, exact);
    const double p3 = corner(a.lo, b.hi, exact), p4 = corner(a.hi, b.hi, exact);
    lo = std::min(std::min(p1, p2), std::min(p3, p4));
    hi = std::max(std::max(p1, p2), std::max(p3, p4));
  }
  if (!exact) {
    lo = dn(lo);
    hi = up(hi);
  }
  return signed_({lo, hi}, a, b);
}

// 1/b over the nonzero members of b (the extended reciprocal).
inline I recip(I b) {
  if (b.lo == 0 && b.hi == 0) return full();
  const bool off0 = b.lo > 0 || b.hi < 0;
  double lo = (off0 || b.lo == 0) ? dn(1.0 / b.hi) : -kInf;
  double hi = (off0 || b.hi == 0) ? up(1.0 / b.lo) : kInf;
  if (b.lo >= 0) lo = std::max(lo, 0.0);
  if (b.hi <= 0) hi = std::min(hi, 0.0);
  return {lo, hi};
}

inline I div(I a, I b) {
  if (b.lo > 0 || b.hi < 0) {
    const double q[4] = {a.lo / b.lo, a.lo / b.hi, a.hi / b.lo, a.hi / b.hi};
    // inf/inf corners are NaN; the other corners already reach 0 and +-inf there.
    double lo = kInf, hi = -kInf;
    for (double v : q) {
      lo = std::fmin(lo, v);
      hi = std::fmax(hi, v);
    }
    return signed_({dn(lo), up(hi)}, a, b);
  }
  return mul(a, recip(b));
}

// The range of an even power over a, from the powers of its ends (unrounded).
inline I even_range(I a, double lo_n, double hi_n) {
  if (a.lo >= 0) return {lo_n, hi_n};
  if (a.hi <= 0) return {hi_n, lo_n};
  return {0.0, std::max(lo_n, hi_n)};
}

inline I sqr(I a) {
  const I r = even_range(a, a.lo * a.lo, a.hi * a.hi);
  return {std::max(dn(r.lo), 0.0), up(r.hi)};
}

inline I keep_sign(I r, I a) {
  if (a.lo >= 0) r.lo = std::max(r.lo, 0.0);
  if (a.hi <= 0) r.hi = std::min(r.hi, 0.0);
  return r;
}

inline double mig(I a) { return has0(a) ? 0.0 : std::min(std::fabs(a.lo), std::fabs(a.hi)); }
inline double mag(I a) { return std::max(std::fabs(a.lo), std::fabs(a.hi)); }

// x**n by repeated squaring for an integer 3 <= n <= 16: at most 8 products,
// so within (1 + 2**-53)**8 - 1 < 2**-49 (kRel) of the true power where no
// product leaves the normal range; where one underflows, so does x**n (each
// factor is at most |x|**n when |x| < 1), and the absolute widening by the
// smallest normal covers it.  pow() costs several times as much.
inline double ipow(double x, unsigned n) {
  double out = 1.0, base = x;
  bool first = true;
  while (n) {
    if (n & 1u) {
      out = first ? base : out * base;
      first = false;
    }
    n >>= 1u;
    if (n) base *= base;
  }
  return out;
}

// a**n for an integer n >= 1.
I pow_int(I a, double n) {
  if (n == 1) return a;
  if (n == 2) return sqr(a);
  const bool small = n <= 16;
  const double lo_n = small ? ipow(a.lo, static_cast<unsigned>(n)) : std::pow(a.lo, n);
  const double hi_n = small ? ipow(a.hi, static_cast<unsigned>(n)) : std::pow(a.hi, n);
  if (std::fmod(n, 2.0) == 1.0) return keep_sign({dn_t(lo_n), up_t(hi_n)}, a);
  const I r = even_range(a, lo_n, hi_n);
  return {std::max(dn_t(r.lo), 0.0), up_t(r.hi)};
}

// A function's domain: [lower, upper], each end open or closed.
struct Domain {
  double lower, upper;
  bool open_lower, open_upper;
};
constexpr Domain kEverywhere = {-kInf, kInf, false, false};

// Clips a to the domain: undefined where a leaves it, empty where no member
// is in it.
inline I restrict(I a, const Domain& d, bool& undefined, bool& empty) {
  undefined = d.open_lower ? a.lo <= d.lower : a.lo < d.lower;
  empty = d.open_lower ? a.hi <= d.lower : a.hi < d.lower;
  const double lo = std::max(a.lo, d.lower);
  undefined = undefined || (d.open_upper ? a.hi >= d.upper : a.hi > d.upper);
  empty = empty || (d.open_upper ? lo >= d.upper : lo > d.upper);
  const double hi = std::min(a.hi, d.upper);
  empty = empty || lo > hi;
  return {lo, std::max(lo, hi)};
}

inline I restrict_below(I a, double lower, bool open, bool& undefined, bool& empty) {
  return restrict(a, {lower, kInf, open, false}, undefined, empty);
}

// a**c for a constant c; sets undefined where a holds points outside the domain.
I pow_const(I a, double c, bool& undefined) {
  undefined = false;
  if (c == 0) return point(1.0);  // numpy: x**0 == 1 for every x
  if (!std::isfinite(c)) {
    undefined = true;
    return full();
  }
  if (c == std::floor(c)) {
    if (c > 0) return pow_int(a, c);
    undefined = has0(a);
    return recip(pow_int(a, -c));
  }
  // A non-integer power needs a base >= 0 (> 0 when c < 0).
  bool empty;
  const I b = restrict_below(a, 0.0, c < 0, undefined, empty);
  if (empty) return full();
  I r = c > 0 ? I{dn_t(std::pow(b.lo, c)), up_t(std::pow(b.hi, c))}
              : I{dn_t(std::pow(b.hi, c)), up_t(std::pow(b.lo, c))};
  return {std::max(r.lo, 0.0), r.hi};
}

// Where a may contain phase + k * period for an integer k (errs towards true).
inline bool hits(I a, double phase, double period) {
  const double tl = (a.lo - phase) / period, th = (a.hi - phase) / period;
  return std::floor(th + 1e-12 * (1.0 + std::fabs(th))) >=
         std::ceil(tl - 1e-12 * (1.0 + std::fabs(tl)));
}

// sin or cos: end values, and +-1 where a maximum or minimum lies inside.
I wave(bool is_sin, I a) {
  const double top = is_sin ? kPi / 2 : 0.0, bottom = is_sin ? -kPi / 2 : kPi;
  const double f1 = is_sin ? std::sin(a.lo) : std::cos(a.lo);
  const double f2 = is_sin ? std::sin(a.hi) : std::cos(a.hi);
  // NaN at infinite ends: those boxes hit both extrema.
  double lo = hits(a, bottom, 2 * kPi) ? -1.0 : dn_t(std::fmin(f1, f2));
  double hi = hits(a, top, 2 * kPi) ? 1.0 : up_t(std::fmax(f1, f2));
  if (std::isnan(f1) || std::isnan(f2)) lo = -1.0, hi = 1.0;
  return {std::clamp(lo, -1.0, 1.0), std::clamp(hi, -1.0, 1.0)};
}

const I kOne = {1.0, 1.0};

template <class F>
inline I increasing(F fn, I a) {
  return {dn_t(fn(a.lo)), up_t(fn(a.hi))};
}
template <class F>
inline I decreasing(F fn, I a) {
  return {dn_t(fn(a.hi)), up_t(fn(a.lo))};
}
// Intersects with a range that holds every true value (exact bounds stay exact).
inline I clip(I a, double lower, double upper) {
  return {std::clamp(a.lo, lower, upper), std::clamp(a.hi, lower, upper)};
}
// An increasing function with fn(0) = 0 whose range lies in [lower, upper].
template <class F>
inline I through0(F fn, I a, double lower = -kInf, double upper = kInf) {
  return clip(keep_sign(increasing(fn, a), a), lower, upper);
}
// IEEE 754 square roots are correctly rounded: no libm widening.
inline I sqrt_iv(I a) { return {std::max(dn(std::sqrt(a.lo)), 0.0), up(std::sqrt(a.hi))}; }
inline I exp_iv(I a) { return {std::max(dn_t(std::exp(a.lo)), 0.0), up_t(std::exp(a.hi))}; }
inline I cosh_iv(I a) {
  return {std::max(dn_t(std::cosh(mig(a))), 1.0), up_t(std::cosh(mag(a)))};
}
// ln c, known only to within its rounding.
inline I ln_const(double c) {
  const double l = std::log(c);
  return {dn(l), up(l)};
}
// The derivative of a non-decreasing step function: 0, or [0, inf] across a jump.
inline I steps(bool jump) { return {0.0, jump ? kInf : 0.0}; }
// 1 / sqrt(1 - a**2), the slope of asin.
inline I asin_slope(I a) { return recip(sqrt_iv(clip(sub(kOne, sqr(a)), 0.0, kInf))); }
inline double sign(double x) { return x > 0 ? 1.0 : (x < 0 ? -1.0 : 0.0); }

#define RDMESH_LIBM(fn) [](double x) { return std::fn(x); }

// The domain of a unary function (kEverywhere: no restriction).
inline Domain domain_of(std::int32_t op) {
  switch (op) {
    case IV_SQRT:
      return {0.0, kInf, false, false};
    case IV_LOG:
    case IV_LOG2:
    case IV_LOG10:
      return {0.0, kInf, true, false};
    case IV_LOG1P:
      return {-1.0, kInf, true, false};
    case IV_ASIN:
    case IV_ACOS:
      return {-1.0, 1.0, false, false};
    case IV_ACOSH:
      return {1.0, kInf, false, false};
    case IV_ATANH:
      return {-1.0, 1.0, true, true};
    default:
      return kEverywhere;
  }
}

// The range of a unary function over a (a within its domain).
I unary_value(std::int32_t op, I a) {
  switch (op) {
    case IV_SQRT:
      return sqrt_iv(a);
    case IV_EXP:
      return exp_iv(a);
    case IV_LOG:
      return increasing(RDMESH_LIBM(log), a);
    case IV_ABS:
      return {mig(a), mag(a)};
    case IV_SIN:
      return wave(true, a);
    case IV_COS:
      return wave(false, a);
    case IV_ASIN:
      return through0(RDMESH_LIBM(asin), a);
    case IV_ACOS:
      return clip(decreasing(RDMESH_LIBM(acos), a), 0.0, kInf);
    case IV_ATAN:
      return through0(RDMESH_LIBM(atan), a);
    case IV_SINH:
      return through0(RDMESH_LIBM(sinh), a);
    case IV_COSH:
      return cosh_iv(a);
    case IV_TANH:
      return through0(RDMESH_LIBM(tanh), a, -1.0, 1.0);
    case IV_ASINH:
      return through0(RDMESH_LIBM(asinh), a);
    case IV_ACOSH:
      return clip(increasing(RDMESH_LIBM(acosh), a), 0.0, kInf);
    case IV_ATANH:
      return through0(RDMESH_LIBM(atanh), a);
    case IV_EXPM1:
      return clip(through0(RDMESH_LIBM(expm1), a), -1.0, kInf);
    case IV_LOG1P:
      return keep_sign(increasing(RDMESH_LIBM(log1p), a), a);
    case IV_LOG2:
      return increasing(RDMESH_LIBM(log2), a);
    case IV_LOG10:
      return increasing(RDMESH_LIBM(log10), a);
    case IV_CBRT:
      return through0(RDMESH_LIBM(cbrt), a);
    case IV_SIGN:
      return {sign(a.lo), sign(a.hi)};
    case IV_FLOOR:
      return {std::floor(a.lo), std::floor(a.hi)};
    case IV_CEIL:
      return {std::ceil(a.lo), std::ceil(a.hi)};
    default:
      return full();  // unreachable: not a unary function
  }
}

// The derivative of a unary function over a (within its domain), given its
// range v.  The formulas retrace the point derivatives of
// rdmesh.surfaces.pointwise (1/sqrt(1 - u*u) for asin, ...), so that an
// enclosure on a point box also holds the rounded point derivative.  At kinks
// and jumps: the hull of both sides.
I unary_derivative(std::int32_t op, I a, I v) {
  switch (op) {
    case IV_SQRT:
      return mul(point(0.5), recip(v));
    case IV_EXP:
      return v;
    case IV_LOG:
      return recip(a);
    case IV_ABS:  // sign(u), and the hull [-1, 1] of both branches where 0 is in a
      return {a.lo > 0 ? 1.0 : -1.0, a.hi < 0 ? -1.0 : 1.0};
    case IV_SIN:
      return wave(false, a);
    case IV_COS:
      return neg(wave(true, a));
    case IV_ASIN:
      return asin_slope(a);
    case IV_ACOS:
      return neg(asin_slope(a));
    case IV_ATAN:
      return recip(add(kOne, sqr(a)));
    case IV_SINH:
      return cosh_iv(a);
    case IV_COSH:
      return through0(RDMESH_LIBM(sinh), a);
    case IV_TANH:
      return clip(sub(kOne, sqr(v)), 0.0, 1.0);
    case IV_ASINH:
      return recip(sqrt_iv(add(sqr(a), kOne)));
    case IV_ACOSH:
      return recip(sqrt_iv(clip(sub(sqr(a), kOne), 0.0, kInf)));
    case IV_ATANH:
      return recip(clip(sub(kOne, sqr(a)), 0.0, kInf));
    case IV_EXPM1:
      return exp_iv(a);
    case IV_LOG1P:
      return recip(add(kOne, a));
    case IV_LOG2:
      return recip(mul(a, ln_const(2.0)));
    case IV_LOG10:
      return recip(mul(a, ln_const(10.0)));
    case IV_CBRT:
      return recip(mul(point(3.0), sqr(v)));
    case IV_SIGN:
      return steps(has0(a));
    case IV_FLOOR:
    case IV_CEIL:
      return steps(std::ceil(a.lo) <= a.hi);
    default:
      return full();  // unreachable: not a unary function
  }
}

#undef RDMESH_LIBM

struct Dual {
  I v;
  I g[3];
};

// Runs the program on one box; returns the last register and whether the box
// may hold points where f is undefined.
class Machine {
 public:
  Machine(const std::vector<IntervalInstruction>& program, bool gradient)
      : prog_(program), regs_(program.size()), grad_(program.size(), 0) {
    for (std::size_t i = 0; i < prog_.size(); ++i) {
      const auto& p = prog_[i];
      switch (p.op) {
        case IV_CONST:
          grad_[i] = 0;
          break;
        case IV_VAR:
          grad_[i] = static_cast<std::uint8_t>(1u << p.a);
          break;
        case IV_ADD:
        case IV_SUB:
        case IV_MUL:
        case IV_DIV:
        case IV_MIN:
        case IV_MAX:
        case IV_POW:
        case IV_HYPOT:
          grad_[i] = grad_[p.a] | grad_[p.b];
          break;
        case IV_ATAN2:
          // Across the branch cut every component is unbounded.
          grad_[i] = (grad_[p.a] | grad_[p.b]) ? 7 : 0;
          break;
        case IV_POWC:
          // A non-finite exponent makes every component unbounded.
          grad_[i] = p.c == 0 ? 0 : (!std::isfinite(p.c) && grad_[p.a] ? 7 : grad_[p.a]);
          break;
        default:
          grad_[i] = grad_[p.a];
      }
      if (!gradient) grad_[i] = 0;
    }
  }

  bool has_gradient() const { return !grad_.empty() && grad_.back(); }
  // Component k of register r's gradient, exactly 0 where its mask says so.
  I gradient(std::size_t r, int k) const {
    return has(r, k) ? regs_[r].g[k] : point(0.0);
  }

  const Dual& run(const double* lo, const double* hi, bool& undefined) {
    undefined = false;
    for (std::size_t i = 0; i < prog_.size(); ++i) step(i, lo, hi, undefined);
    return regs_.back();
  }

 private:
  // Whether component k of register r's gradient can be nonzero: a mask per
  // register, so that x**2 computes one component, not three (the others
  // would be exact zeros).
  bool has(std::size_t r, int k) const { return (grad_[r] >> k) & 1u; }

  void step(std::size_t i, const double* lo, const double* hi, bool& undef) {
    const IntervalInstruction& p = prog_[i];
    Dual& r = regs_[i];
    const bool g = grad_[i] != 0;
    switch (p.op) {
      case IV_CONST:
        if (!std::isfinite(p.c)) {  // e.g. 1e999: not a real number
          undef = true;
          r.v = {dn(p.c), up(p.c)};
        } else {
          r.v = point(p.c);
        }
        return;
      case IV_VAR:
        r.v = {lo[p.a], hi[p.a]};
        for (int k = 0; k < 3; ++k) r.g[k] = point(k == p.a ? 1.0 : 0.0);
        return;
      case IV_NEG: {
        const Dual& a = regs_[p.a];
        r.v = neg(a.v);
        if (g)
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = neg(gradient(p.a, k));
        return;
      }
      case IV_ADD:
      case IV_SUB: {
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        const bool minus = p.op == IV_SUB;
        r.v = minus ? sub(a.v, b.v) : add(a.v, b.v);
        if (g)
          for (int k = 0; k < 3; ++k) {
            if (!has(i, k)) continue;
            const I ga = gradient(p.a, k), gb = gradient(p.b, k);
            r.g[k] = minus ? sub(ga, gb) : add(ga, gb);
          }
        return;
      }
      case IV_MUL: {
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        if (g)
          for (int k = 0; k < 3; ++k) {
            // d(uv) = du v + dv u, in the order of the tree walk.
            const bool ha = has(p.a, k), hb = has(p.b, k);
            if (ha && hb)
              r.g[k] = add(mul(a.g[k], b.v), mul(b.g[k], a.v));
            else if (ha)
              r.g[k] = mul(a.g[k], b.v);
            else if (hb)
              r.g[k] = mul(b.g[k], a.v);
          }
        r.v = mul(a.v, b.v);
        return;
      }
      case IV_DIV: {
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        if (has0(b.v)) undef = true;
        const I q = div(a.v, b.v);
        if (g) {
          // d(u/v) = (du - (u/v) dv) * (1/v), as the point dual computes it.
          const I rb = recip(b.v);
          for (int k = 0; k < 3; ++k) {
            if (!has(i, k)) continue;
            I t;
            if (has(p.b, k)) {
              const I dv = mul(b.g[k], q);
              t = has(p.a, k) ? sub(a.g[k], dv) : neg(dv);
            } else {
              t = a.g[k];
            }
            r.g[k] = mul(t, rb);
          }
        }
        r.v = q;
        return;
      }
      case IV_POWC: {
        const Dual& a = regs_[p.a];
        bool u = false;
        r.v = pow_const(a.v, p.c, u);
        undef = undef || u;
        if (g) {
          if (!std::isfinite(p.c)) {
            for (int k = 0; k < 3; ++k) r.g[k] = full();  // the mask is all three
          } else {
            bool ignored = false;
            const I d = mul(point(p.c), pow_const(a.v, p.c - 1.0, ignored));
            for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = mul(a.g[k], d);
          }
        }
        return;
      }
      case IV_TAN: {
        const Dual& a = regs_[p.a];
        const bool pole = hits(a.v, kPi / 2, kPi);
        undef = undef || pole;
        r.v = pole ? full() : increasing([](double u) { return std::tan(u); }, a.v);
        if (g) {
          const I d = recip(sqr(wave(false, a.v)));  // 1 / cos(u)**2
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = mul(a.g[k], d);
        }
        return;
      }
      case IV_MIN:
      case IV_MAX: {
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        bool only_a, only_b;
        if (p.op == IV_MIN) {
          only_a = a.v.hi < b.v.lo;
          only_b = b.v.hi < a.v.lo;
          r.v = {std::min(a.v.lo, b.v.lo), std::min(a.v.hi, b.v.hi)};
        } else {
          only_a = a.v.lo > b.v.hi;
          only_b = b.v.lo > a.v.hi;
          r.v = {std::max(a.v.lo, b.v.lo), std::max(a.v.hi, b.v.hi)};
        }
        if (g)
          for (int k = 0; k < 3; ++k) {
            if (!has(i, k)) continue;
            const I ga = gradient(p.a, k), gb = gradient(p.b, k);
            // Where both branches can be taken, the hull of both gradients.
            r.g[k] = only_a ? ga
                     : only_b ? gb
                              : I{std::min(ga.lo, gb.lo), std::max(ga.hi, gb.hi)};
          }
        return;
      }
      case IV_POW: {
        // a**b = exp(b log a) for a > 0.
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        bool u, empty;
        const I base = restrict_below(a.v, 0.0, true, u, empty);
        undef = undef || u;
        const I la = increasing([](double t) { return std::log(t); }, base);
        r.v = empty ? full() : exp_iv(mul(b.v, la));
        if (g) {
          const I da = empty ? full() : mul(b.v, exp_iv(mul(sub(b.v, kOne), la)));
          const I db = empty ? full() : mul(r.v, la);
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = chain(p, k, da, db);
        }
        return;
      }
      case IV_ATAN2: {
        const Dual &y = regs_[p.a], &x = regs_[p.b];
        const bool origin = has0(x.v) && has0(y.v);
        undef = undef || origin;
        // Off the origin and the branch cut (y = 0, x < 0) the angle over a
        // box is continuous, and its extremes are at corners.
        const bool jump = origin || (x.v.lo < 0 && has0(y.v));
        const double c1 = std::atan2(y.v.lo, x.v.lo), c2 = std::atan2(y.v.lo, x.v.hi);
        const double c3 = std::atan2(y.v.hi, x.v.lo), c4 = std::atan2(y.v.hi, x.v.hi);
        const double lo = dn_t(std::min(std::min(c1, c2), std::min(c3, c4)));
        const double hi = up_t(std::max(std::max(c1, c2), std::max(c3, c4)));
        r.v = clip({jump ? -kPiUp : lo, jump ? kPiUp : hi}, -kPiUp, kPiUp);
        if (g) {
          const I r2 = add(sqr(x.v), sqr(y.v));
          const I dy = div(x.v, r2), dx = neg(div(y.v, r2));
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = jump ? full() : chain(p, k, dy, dx);
        }
        return;
      }
      case IV_HYPOT: {
        const Dual &a = regs_[p.a], &b = regs_[p.b];
        r.v = {std::max(dn_t(std::hypot(mig(a.v), mig(b.v))), 0.0),
               up_t(std::hypot(mag(a.v), mag(b.v)))};
        if (g) {
          // u / hypot(u, v), which lies in [-1, 1].
          const I da = clip(div(a.v, r.v), -1.0, 1.0), db = clip(div(b.v, r.v), -1.0, 1.0);
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = chain(p, k, da, db);
        }
        return;
      }
      default: {  // a unary function
        const Dual& a = regs_[p.a];
        I x = a.v;
        bool empty = false;
        const Domain dom = domain_of(p.op);
        if (dom.lower != -kInf || dom.upper != kInf) {
          bool u;
          x = restrict(a.v, dom, u, empty);
          undef = undef || u;
        }
        // Where no member of a is in the domain: [-inf, inf].
        r.v = empty ? full() : unary_value(p.op, x);
        if (g) {
          const I d = empty ? full() : unary_derivative(p.op, x, r.v);
          for (int k = 0; k < 3; ++k)
            if (has(i, k)) r.g[k] = mul(a.g[k], d);
        }
        return;
      }
    }
  }

  // Component k of the gradient of a binary instruction p from its partial
  // derivatives: da d(a)/dk + db d(b)/dk, a term only where its argument
  // depends on coordinate k.
  I chain(const IntervalInstruction& p, int k, I da, I db) const {
    const bool ha = has(p.a, k), hb = has(p.b, k);
    if (ha && hb) return add(mul(regs_[p.a].g[k], da), mul(regs_[p.b].g[k], db));
    if (ha) return mul(regs_[p.a].g[k], da);
    if (hb) return mul(regs_[p.b].g[k], db);
    return point(0.0);
  }

  const std::vector<IntervalInstruction>& prog_;
  std::vector<Dual> regs_;
  std::vector<std::uint8_t> grad_;
};

}  // namespace

void check_interval_program(const std::vector<IntervalInstruction>& program) {
  if (program.empty()) throw std::invalid_argument("the interval program is empty");
  for (std::size_t i = 0; i < program.size(); ++i) {
    const auto& p = program[i];
    const std::string at = "interval program instruction " + std::to_string(i);
    if (p.op < 0 || p.op >= IV_OP_COUNT) throw std::invalid_argument(at + ": unknown opcode");
    if (p.op == IV_CONST) continue;
    if (p.op == IV_VAR) {
      if (p.a < 0 || p.a > 2) throw std::invalid_argument(at + ": axis out of range");
      continue;
    }
    const bool binary = is_binary(p.op);
    const auto bad = [&](std::int32_t r) {
      return r < 0 || static_cast<std::size_t>(r) >= i;
    };
    if (bad(p.a) || (binary && bad(p.b)))
      throw std::invalid_argument(at + ": an argument is not an earlier register");
  }
}

struct BoxEvaluator::Machines {
  Machines(const std::vector<IntervalInstruction>& program, bool with_grad)
      : size(program.size()), box(program, with_grad), centre(program, false) {}
  std::size_t size;
  Machine box, centre;
};

BoxEvaluator::BoxEvaluator(const std::vector<IntervalInstruction>& program, bool gradient,
                           bool mean_value)
    : m_(std::make_unique<Machines>(program, gradient || mean_value)),
      gradient_(gradient),
      mean_value_(mean_value) {}

BoxEvaluator::~BoxEvaluator() = default;

void BoxEvaluator::evaluate(const double* l, const double* h, BoxBounds& out) {
  bool undef = false;
  const Dual& d = m_->box.run(l, h, undef);
  I G[3] = {point(0.0), point(0.0), point(0.0)};
  if (m_->box.has_gradient())
    for (int k = 0; k < 3; ++k) G[k] = m_->box.gradient(m_->size - 1, k);
  for (int k = 0; k < 3; ++k) {
    out.glo[k] = G[k].lo;
    out.ghi[k] = G[k].hi;
  }
  out.lo = d.v.lo;
  out.hi = d.v.hi;
  out.undefined = undef;
  if (mean_value_) tighten(l, h, out);
  if (!gradient_)
    for (int k = 0; k < 3; ++k) out.glo[k] = out.ghi[k] = 0.0;
}

void BoxEvaluator::tighten(const double* l, const double* h, BoxBounds& b) {
  if (b.undefined) return;
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(l[k]) || !std::isfinite(h[k]) || !std::isfinite(b.glo[k]) ||
        !std::isfinite(b.ghi[k]))
      return;
  double m[3];
  for (int k = 0; k < 3; ++k) m[k] = std::clamp(0.5 * l[k] + 0.5 * h[k], l[k], h[k]);
  bool mundef = false;
  const Dual& c = m_->centre.run(m, m, mundef);
  if (mundef) return;
  I total = c.v;
  for (int k = 0; k < 3; ++k)
    total = add(total, mul({b.glo[k], b.ghi[k]}, sub({l[k], h[k]}, point(m[k]))));
  b.lo = std::max(b.lo, total.lo);
  b.hi = std::min(b.hi, total.hi);
}

namespace {

// Boxes [begin, end) of evaluate_intervals, with an evaluator of their own.
void evaluate_range(BoxEvaluator& box, const double* lo, const double* hi, std::size_t begin,
                    std::size_t end, bool gradient, IntervalResult& out) {
  BoxBounds b;
  for (std::size_t i = begin; i < end; ++i) {
    box.evaluate(lo + 3 * i, hi + 3 * i, b);
    if (gradient)
      for (int k = 0; k < 3; ++k) {
        out.glo[3 * i + k] = b.glo[k];
        out.ghi[3 * i + k] = b.ghi[k];
      }
    out.lo[i] = b.lo;
    out.hi[i] = b.hi;
    out.undefined[i] = b.undefined;
  }
}

// Boxes per work item, and at least per thread.
constexpr std::size_t kPerItem = 512;

}  // namespace

IntervalResult evaluate_intervals(const std::vector<IntervalInstruction>& program,
                                  const double* lo, const double* hi, std::size_t n,
                                  bool gradient, bool mean_value) {
  check_interval_program(program);
  IntervalResult out;
  out.lo.resize(n);
  out.hi.resize(n);
  out.undefined.assign(n, 0);
  if (gradient) {
    out.glo.assign(3 * n, 0.0);
    out.ghi.assign(3 * n, 0.0);
  }
  // Boxes are independent: ranges of kPerItem boxes spread over the cores
  // (each writes its own rows, so the result does not depend on the split).
  const std::size_t items = (n + kPerItem - 1) / kPerItem;
  for_each_on_cores(
      items, [&] { return BoxEvaluator(program, gradient, mean_value); },
      [&](BoxEvaluator& box, std::size_t t) {
        evaluate_range(box, lo, hi, t * kPerItem, std::min(n, (t + 1) * kPerItem), gradient, out);
      },
      std::max<std::size_t>(1, n / kPerItem));
  return out;
}

}  // namespace rdmesh
