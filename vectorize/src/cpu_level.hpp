#pragma once
// The hottest host loops built twice: for the instruction set the whole program is built for
// (TRIXEL_CPU_LEVEL, x86-64-v2 by default, which every x86-64 CPU of the last fifteen years runs) and
// for x86-64-v3 (AVX2, FMA, BMI2), the second chosen when the program runs on a CPU that has it. A
// stage marks the function that does its work with TRIXEL_V3_CLONE: every call inside it is inlined
// (GCC's flatten), so the whole loop nest is compiled for x86-64-v3 in that copy, and the stage's entry
// calls the copy when v3_loops() says so. Floating-point contraction is off everywhere
// (-ffp-contract=off), so both copies compute the same numbers in the same order: the results are the
// same to the bit (tests compare them), only faster. Only the grouping has such a copy: its colour
// conversions ran about a fifth faster so on the Kodak photographs, where the simplification, the trixel
// sums, the PSLG, the polygons and the SVG text did not (built whole for x86-64-v3, or copied so, they
// took the same time or longer).

namespace vectorize::detail {

/// Whether the x86-64-v3 copies run: the CPU has x86-64-v3 and nothing turned them off
/// (set_v3_loops(false), or TRIXEL_CPU_BASELINE=1 in the environment). False where this build has no
/// such copies.
bool v3_loops() noexcept;

/// Turns the x86-64-v3 copies off (false) or back on where the CPU has them (true); for tests.
void set_v3_loops(bool allowed) noexcept;

} // namespace vectorize::detail

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX2__)
#define TRIXEL_HAVE_V3_LOOPS 1
#define TRIXEL_V3_CLONE __attribute__((target("arch=x86-64-v3"), flatten))
#else
#define TRIXEL_HAVE_V3_LOOPS 0
#endif
