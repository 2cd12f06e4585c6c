# The CUDA backend: included by CMakeLists.txt when RAYCLOTH_CUDA is ON. When nvcc is found it
# enables CUDA, adds the kernels to the `raycloth` library and sets RAYCLOTH_HAS_CUDA ON (include()
# shares the caller's scope); otherwise it leaves everything as it was and the CPU-only build
# compiles src/sim/cuda_unavailable.cpp instead.
include(CheckLanguage)
check_language(CUDA)
if(NOT CMAKE_CUDA_COMPILER)
  message(STATUS "raycloth: no CUDA compiler found, building without the CUDA backend")
  return()
endif()

# Ampere (A100) and Hopper (H100/H200) by default; -DCMAKE_CUDA_ARCHITECTURES=... overrides.
if(NOT DEFINED CMAKE_CUDA_ARCHITECTURES)
  set(CMAKE_CUDA_ARCHITECTURES "80;90")
endif()
enable_language(CUDA)
find_package(CUDAToolkit REQUIRED)
# `raycloth` existed before CUDA was enabled, so its CUDA properties are set here, not inherited.
set_target_properties(raycloth PROPERTIES CUDA_ARCHITECTURES "${CMAKE_CUDA_ARCHITECTURES}")
# C++20 like the rest (std::atomic_ref, std::countl_zero on the host side of the shared headers);
# the CUDA dialect follows the target's CXX_STANDARD. CMake before 3.26 does not know nvcc's C++20
# flag (generate error "requires the language dialect CUDA20"): tell it.
if(NOT DEFINED CMAKE_CUDA20_STANDARD_COMPILE_OPTION)
  set(CMAKE_CUDA20_STANDARD_COMPILE_OPTION "-std=c++20")
  set(CMAKE_CUDA20_EXTENSION_COMPILE_OPTION "-std=c++20")
endif()
set_target_properties(raycloth PROPERTIES CUDA_STANDARD 20 CUDA_STANDARD_REQUIRED ON)

target_sources(raycloth PRIVATE
  ${CMAKE_CURRENT_SOURCE_DIR}/src/sim/cuda_backend.cu
  ${CMAKE_CURRENT_SOURCE_DIR}/src/collide/cuda/device_bvh.cu)
target_link_libraries(raycloth PUBLIC CUDA::cudart)

# nvcc rejects GCC warning flags given directly (`nvcc fatal: Unknown option '-Wall'`): keep the
# library's existing options for C++ only and hand the same flags to the host compiler for CUDA.
get_target_property(_raycloth_opts raycloth COMPILE_OPTIONS)
if(_raycloth_opts)
  set(_raycloth_cxx_opts "")
  foreach(_opt IN LISTS _raycloth_opts)
    if(_opt MATCHES "^\\$<")
      list(APPEND _raycloth_cxx_opts "${_opt}")  # already a generator expression: keep as is
    else()
      list(APPEND _raycloth_cxx_opts "$<$<COMPILE_LANGUAGE:CXX>:${_opt}>")
      if(_opt MATCHES "^-W")
        list(APPEND _raycloth_cxx_opts "$<$<COMPILE_LANGUAGE:CUDA>:-Xcompiler=${_opt}>")
      endif()
    endif()
  endforeach()
  set_property(TARGET raycloth PROPERTY COMPILE_OPTIONS "${_raycloth_cxx_opts}")
endif()
# Line info for profilers; relaxed constexpr so that std:: constexpr helpers work in kernels.
target_compile_options(raycloth PRIVATE $<$<COMPILE_LANGUAGE:CUDA>:-lineinfo --expt-relaxed-constexpr --extended-lambda>)

set(RAYCLOTH_HAS_CUDA ON)
