// One macro marks code that compiles for both the CPU and the GPU (see docs/architecture.md).
#pragma once
#if defined(__CUDACC__)
#define RC_HD __host__ __device__ __forceinline__
#else
#define RC_HD inline
#endif
