# The GPUs seamfit's CUDA code is built for: native code for every generation from Turing
# (sm_75, the oldest CUDA 13 supports) to the newest the compiler knows, and PTX of the
# newest, which the driver compiles once for later GPUs.
#
#   seamfit_cuda_architectures(OUT VERSION): OUT gets the list for nvcc VERSION, in the
#   syntax of CMake's CUDA_ARCHITECTURES.
function(seamfit_cuda_architectures out version)
  set(archs 75-real 80-real 86-real 89-real 90-real)
  set(ptx 90)
  if(version VERSION_GREATER_EQUAL 12.8)
    # Blackwell: data centre (sm_100) and consumer (sm_120) cards.
    list(APPEND archs 100-real 120-real)
    set(ptx 120)
  endif()
  list(APPEND archs ${ptx}-virtual)
  set(${out} "${archs}" PARENT_SCOPE)
endfunction()
