// A CUDA library loaded with dlopen at its first use (cuBLAS for the MLP, cuSOLVER and cuBLAS for the
// dense Cholesky): programs that never call it do not pay its load time at every start (cuBLAS ~60 ms).
// Host side only; compiled with TOPO_HAVE_CUDA.
#pragma once

#include <dlfcn.h>

#include <initializer_list>
#include <string>

namespace topo_gaussian::cuda_detail {

/// The first of `names` that loads (e.g. {"libcublas.so.13", "libcublas.so.12", "libcublas.so"}), or
/// null with *error saying why.
inline void* openCudaLibrary(std::initializer_list<const char*> names, std::string* error) {
  void* lib = nullptr;
  for (const char* name : names)
    if ((lib = dlopen(name, RTLD_NOW | RTLD_LOCAL))) return lib;
  const char* e = dlerror();
  *error = std::string(*names.begin()) + " could not be loaded (" + (e ? e : "not found") + ")";
  return nullptr;
}

/// *f = the function `name` of lib, or `name`_v2 first where v2 is true (cuBLAS's versioned names).
template <class F>
bool resolveSymbol(void* lib, const char* name, F* f, bool v2 = false) {
  void* p = v2 ? dlsym(lib, (std::string(name) + "_v2").c_str()) : nullptr;
  if (!p) p = dlsym(lib, name);
  *f = reinterpret_cast<F>(p);
  return p != nullptr;
}

}  // namespace topo_gaussian::cuda_detail
