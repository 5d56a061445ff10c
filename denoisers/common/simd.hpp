#pragma once
// Which SIMD build of the filter kernels runs. The à-trous and Poisson-blur kernels
// (atrous_kernel.hpp, poisson_blur_kernel.hpp) are compiled twice: for eight AVX2 lanes (the
// build's x86-64-v3 baseline) and for sixteen AVX-512 lanes (simd_avx512.cpp, its own flags).
// The AVX-512 build runs where the CPU has AVX-512 F, VL, BW and DQ and the environment does not
// set ARENA_NO_AVX512 (to time what a machine without it would); both give the same bits.
namespace arena {

bool simdUsesAvx512();
// allowAvx512(false) forces the AVX2 kernels (tests compare the two); returns the previous setting.
bool allowAvx512(bool allow);

}  // namespace arena
