#pragma once
// Eigen's memory layout, checked where gipdyn's headers are compiled.
//
// gipdyn hands Eigen objects to Debian's liborocos-kdl (KDL::JntArray holds an
// Eigen::VectorXd), and a program hands Eigen objects to gipdyn. Every side
// must agree on Eigen's alignment: that of fixed-size members (which sets the
// layout of structs) and that of the heap (which decides whether Eigen takes
// memory from malloc or over-aligns it by hand and keeps the offset in front
// of the block). Debian builds its libraries for the architecture's baseline,
// where Eigen aligns to 16 bytes and uses malloc. An AVX instruction set
// (-march=native on an AVX CPU, -mavx, -mavx2, -march=x86-64-v3, ...) raises
// Eigen's heap alignment to 32 or 64 bytes even when EIGEN_MAX_ALIGN_BYTES is
// set to 16, and then memory that one side allocates is freed or written by the
// other: a crash or a corrupted heap. So the build stops here instead.
#include <Eigen/Core>

// The fix the message names: without the AVX family (-mno-avx after -march=...,
// as the GIPDYN_NATIVE build does) Eigen keeps the baseline's layout. Code that
// must use AVX does so on raw arrays (gipdyn/detail/factor_pair_product.hpp).
#if EIGEN_MAX_STATIC_ALIGN_BYTES != 16 || EIGEN_DEFAULT_ALIGN_BYTES != 16
#error "gipdyn: Eigen is compiled with another alignment than Debian's liborocos-kdl (16 bytes), which gipdyn shares Eigen objects with: compile this file without -march=native or -mavx*, or add -mno-avx after them (to tune gipdyn itself for this CPU, configure it with GIPDYN_NATIVE=ON)"
#endif
