// Interval enclosures of an expression and of its gradient over many boxes: a
// straight-line program (one instruction per node of the expression tree,
// compiled by rdmesh.surfaces.interval_program) run box after box as interval
// dual numbers, with a rule for every function of the expression grammar:
// domains and undefined flags, Clarke hulls at kinks, widening of libm
// results and outward rounding, as rdmesh.surfaces.intervals states them.
// tests/interval_reference.py applies the same rules in numpy, as the
// reference the tests compare this evaluator against.  Compiled with
// -ffp-contract=off: a fused multiply-add would change what was rounded.
#pragma once

#include <cfloat>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace rdmesh {

// Opcodes; the result of instruction i is register i.  a, b: argument
// registers (for VAR, a is the axis); c: the constant of CONST and POWC.
// Unary functions carry the name of the expression function they bound;
// POW is a power with a variable exponent (POWC: a constant one).  Python
// reads the numbers from the extension (rdmesh.core.INTERVAL_OPS).
enum IntervalOp : std::int32_t {
  IV_CONST = 0,
  IV_VAR = 1,
  IV_NEG = 2,
  IV_ADD = 3,
  IV_SUB = 4,
  IV_MUL = 5,
  IV_DIV = 6,
  IV_POWC = 7,
  IV_SQRT = 8,
  IV_EXP = 9,
  IV_LOG = 10,
  IV_ABS = 11,
  IV_MIN = 12,
  IV_MAX = 13,
  IV_SIN = 14,
  IV_COS = 15,
  IV_TAN = 16,
  IV_ASIN = 17,
  IV_ACOS = 18,
  IV_ATAN = 19,
  IV_SINH = 20,
  IV_COSH = 21,
  IV_TANH = 22,
  IV_ASINH = 23,
  IV_ACOSH = 24,
  IV_ATANH = 25,
  IV_EXPM1 = 26,
  IV_LOG1P = 27,
  IV_LOG2 = 28,
  IV_LOG10 = 29,
  IV_CBRT = 30,
  IV_SIGN = 31,
  IV_FLOOR = 32,
  IV_CEIL = 33,
  IV_POW = 34,
  IV_ATAN2 = 35,  // atan2(a, b): a is y, b is x
  IV_HYPOT = 36,
  IV_OP_COUNT = 37,
};

// Each opcode's name, in opcode order: the function names of
// rdmesh.surfaces.ir for the functions.
inline constexpr const char* kIntervalOpNames[IV_OP_COUNT] = {
    "const", "var",   "neg",   "add",   "sub",   "mul",   "div",   "powc",  "sqrt", "exp",
    "log",   "abs",   "min",   "max",   "sin",   "cos",   "tan",   "asin",  "acos", "atan",
    "sinh",  "cosh",  "tanh",  "asinh", "acosh", "atanh", "expm1", "log1p", "log2", "log10",
    "cbrt",  "sign",  "floor", "ceil",  "pow",   "atan2", "hypot"};

// Opcodes with two argument registers.
inline bool is_binary(std::int32_t op) {
  return op == IV_ADD || op == IV_SUB || op == IV_MUL || op == IV_DIV || op == IV_MIN ||
         op == IV_MAX || op == IV_POW || op == IV_ATAN2 || op == IV_HYPOT;
}

// Relative widening of results of libm functions, which are not correctly
// rounded (rdmesh.surfaces.intervals.REL_WIDENING): 2**-49, 8 to 16 ulps.
inline constexpr double kRelWidening = 1.0 / 562949953421312.0;

struct IntervalInstruction {
  std::int32_t op, a, b;
  double c;
};

struct IntervalResult {
  std::vector<double> lo, hi, glo, ghi;  // (n,), (n,), (n, 3), (n, 3)
  std::vector<std::uint8_t> undefined;   // (n,)
};

// Bounds of the value and of the gradient over one box.
struct BoxBounds {
  double lo, hi, glo[3], ghi[3];
  bool undefined;
};

// Whether grad f . d keeps one sign over the box's gradient bounds (as
// dot_bounds of tests/interval_reference.py decides it): components with
// d == 0 add nothing, a non-finite bound settles nothing, and a few ulps of
// slack cover the rounding of three products and two sums.
inline bool gradient_keeps_sign(const BoxBounds& g, const double* d) {
  double lo = 0.0, hi = 0.0, mag = 0.0;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0.0) continue;
    const double p1 = g.glo[k] * d[k], p2 = g.ghi[k] * d[k];
    const double l = p1 < p2 ? p1 : p2, h = p1 < p2 ? p2 : p1;
    if (!std::isfinite(l) || !std::isfinite(h)) return false;
    lo += l;
    hi += h;
    mag += std::fabs(l) > std::fabs(h) ? std::fabs(l) : std::fabs(h);
  }
  const double slack = 8 * DBL_EPSILON * mag + DBL_MIN;
  return lo - slack > 0 || hi + slack < 0;
}

// Bounds one box at a time with machines of its own (one per thread): what
// evaluate_intervals does for each box.  The program must have been checked.
class BoxEvaluator {
 public:
  BoxEvaluator(const std::vector<IntervalInstruction>& program, bool gradient, bool mean_value);
  ~BoxEvaluator();
  BoxEvaluator(const BoxEvaluator&) = delete;
  BoxEvaluator& operator=(const BoxEvaluator&) = delete;
  // The box [lo, hi] (3 values each); glo/ghi are zero without gradient.
  void evaluate(const double* lo, const double* hi, BoxBounds& out);
  // Intersects out's value bounds with the mean-value form f(m) + G . (X - m)
  // (m the box centre), where f is defined on the whole box: what evaluate does
  // with mean_value.  out must hold the box's natural bounds and gradient.
  void tighten(const double* lo, const double* hi, BoxBounds& out);

 private:
  struct Machines;
  std::unique_ptr<Machines> m_;
  bool gradient_, mean_value_;
};

// Checks the program (opcodes, argument registers earlier than their
// instruction, axes 0..2); throws std::invalid_argument otherwise.
void check_interval_program(const std::vector<IntervalInstruction>& program);

// Bounds of the program's last register over boxes [lo_i, hi_i] (n rows of 3).
// gradient: also bound the gradient; mean_value: intersect the value bounds
// with the mean-value form f(m) + G . (X - m) (m the box centre) where f is
// defined on the whole box.
IntervalResult evaluate_intervals(const std::vector<IntervalInstruction>& program,
                                  const double* lo, const double* hi, std::size_t n,
                                  bool gradient, bool mean_value);

}  // namespace rdmesh
