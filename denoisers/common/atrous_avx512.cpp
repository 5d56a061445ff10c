// The à-trous kernel for sixteen lanes, built with AVX-512 enabled (CMakeLists.txt sets this
// file's flags) and called only after a run-time CPU check (atrous.cpp). Nothing else lives here:
// see atrous_kernel.hpp on keeping standard-library templates out.
#include "denoisers/common/atrous_kernel.hpp"

#ifndef __AVX512F__
#error "atrous_avx512.cpp must be compiled with -mavx512f -mavx512vl -mavx512bw -mavx512dq"
#endif

namespace arena::atrous_detail {

FilterRowFunction selectFilterRowAvx512(bool depth, bool luminance, NormalTerm normal,
                                        Carry carry) {
  return selectFilterRow<Lanes16>(depth, luminance, normal, carry);
}

}  // namespace arena::atrous_detail
