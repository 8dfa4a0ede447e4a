// Private to the glue: what an FMU binary does when it is unloaded, for the C++ runtime it links
// statically. Included by exactly one file of each binary: its C API (fmi2_api.cpp or fmi3_api.cpp).
#pragma once

#if defined(FMUGLUE_STATIC_LIBSTDCXX)
// The statically linked libstdc++ allocates its exception emergency pool (72 704 bytes) when the
// binary is loaded and never frees it, so an importer that loads and unloads the FMU repeatedly
// lost that much every time. __gnu_cxx::__freeres(), libstdc++'s hook for memory checkers, frees
// it when the binary is unloaded (the pool is private to this binary: its libstdc++ is hidden).
namespace __gnu_cxx {
void __freeres() noexcept;
}
__attribute__((destructor)) static void releaseStaticRuntime() { __gnu_cxx::__freeres(); }
#endif

#if defined(FMUGLUE_ZIG_RUNTIME)
// zig links no crtbeginS.o, whose destructor calls __cxa_finalize(&__dso_handle) when the binary
// is unloaded: the destructors of this binary's static objects (registered with __cxa_atexit)
// then stayed in the process's exit list, and the process crashed at exit calling into the
// unmapped binary after an importer's dlclose. This destructor does what crtbeginS.o does.
extern "C" void __cxa_finalize(void* dso);
extern "C" __attribute__((visibility("hidden"))) void* __dso_handle;
__attribute__((destructor)) static void finalizeStaticObjects() { __cxa_finalize(&__dso_handle); }
#endif
