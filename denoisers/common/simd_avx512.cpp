// The filter kernels for sixteen lanes, built with AVX-512 enabled (CMakeLists.txt sets this
// file's flags) and called only after a run-time CPU check (simd.hpp). Nothing else lives here:
// see atrous_kernel.hpp on keeping standard-library templates out.
#include "denoisers/common/atrous_kernel.hpp"
#include "denoisers/common/poisson_blur_kernel.hpp"

#ifndef __AVX512F__
#error "simd_avx512.cpp must be compiled with -mavx512f -mavx512vl -mavx512bw -mavx512dq"
#endif

namespace arena {

namespace atrous_detail {
FilterRowFunction selectFilterRowAvx512(bool depth, bool luminance, NormalTerm normal,
                                        Carry carry) {
  return selectFilterRow<Lanes16>(depth, luminance, normal, carry);
}
}  // namespace atrous_detail

namespace poisson_detail {
BlurRowFunction selectBlurRowAvx512(int tapCount, bool skipIdle) {
  return selectBlurRow<Lanes16>(tapCount, skipIdle);
}
}  // namespace poisson_detail

}  // namespace arena
