// Loading an FMU's binary as an importer (the native runners in fmu/rt_runner and
// fmu/closed_loop): binaries/<platform>/<modelIdentifier><suffix> of an extracted FMU, with dlopen
// (LoadLibrary on Windows), and its fmi2 (or fmi3) entry points by name.
#pragma once

#ifdef _WIN32
#include <windows.h>
#else
#include <dlfcn.h>
#endif

#include <cstdio>
#include <string>

#include "fmi2Functions.h"
#include "fmi3Functions.h"

namespace fmuimport {

#ifdef _WIN32
inline const char* const kPlatform = "win64";
inline const char* const kPlatform3 = "x86_64-windows";
inline const char* const kLibSuffix = ".dll";
inline void* openLibrary(const std::string& path, std::string& err) {
  HMODULE h = LoadLibraryA(path.c_str());
  if (!h) err = "LoadLibrary error " + std::to_string(GetLastError());
  return reinterpret_cast<void*>(h);
}
inline void* librarySymbol(void* lib, const char* name) {
  return reinterpret_cast<void*>(GetProcAddress(static_cast<HMODULE>(lib), name));
}
inline void closeLibrary(void* lib) { FreeLibrary(static_cast<HMODULE>(lib)); }
#else
// x86_64: FMI 2.0's linux64. aarch64: FMI 3.0's tuple aarch64-linux, which the FMI 2.0 FMUs use too
// (FMI 2.0 names no ARM platform; docs/fmu.md, "Platforms").
#if defined(__aarch64__)
inline const char* const kPlatform = "aarch64-linux";
inline const char* const kPlatform3 = "aarch64-linux";
#else
inline const char* const kPlatform = "linux64";
inline const char* const kPlatform3 = "x86_64-linux";  // FMI 3.0 platform tuple
#endif
inline const char* const kLibSuffix = ".so";
inline void* openLibrary(const std::string& path, std::string& err) {
  void* h = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!h) err = dlerror();
  return h;
}
inline void* librarySymbol(void* lib, const char* name) { return dlsym(lib, name); }
inline void closeLibrary(void* lib) { dlclose(lib); }
#endif

// The binary of an extracted FMU (of an FMI 3.0 FMU with fmi3).
inline std::string binaryPath(const std::string& unzipdir, const std::string& modelIdentifier, bool fmi3 = false) {
  return unzipdir + "/binaries/" + (fmi3 ? kPlatform3 : kPlatform) + "/" + modelIdentifier + kLibSuffix;
}

// f = the entry point `name`; false (and `err` names it) when the binary lacks it.
template <class F>
bool symbol(void* lib, const char* name, F& f, std::string& err) {
  f = reinterpret_cast<F>(librarySymbol(lib, name));
  if (!f) err = std::string("symbol ") + name + " missing in the FMU binary";
  return f != nullptr;
}

// The co-simulation entry points an importer calls.
struct Fmi2Api {
  fmi2InstantiateTYPE* instantiate = nullptr;
  fmi2FreeInstanceTYPE* freeInstance = nullptr;
  fmi2SetupExperimentTYPE* setupExperiment = nullptr;
  fmi2EnterInitializationModeTYPE* enterInitializationMode = nullptr;
  fmi2ExitInitializationModeTYPE* exitInitializationMode = nullptr;
  fmi2TerminateTYPE* terminate = nullptr;
  fmi2SetRealTYPE* setReal = nullptr;
  fmi2SetIntegerTYPE* setInteger = nullptr;
  fmi2SetBooleanTYPE* setBoolean = nullptr;
  fmi2SetStringTYPE* setString = nullptr;
  fmi2GetRealTYPE* getReal = nullptr;
  fmi2GetIntegerTYPE* getInteger = nullptr;
  fmi2GetBooleanTYPE* getBoolean = nullptr;
  fmi2DoStepTYPE* doStep = nullptr;
  fmi2GetRealStatusTYPE* getRealStatus = nullptr;
  fmi2GetBooleanStatusTYPE* getBooleanStatus = nullptr;

  // All of them from `lib`; false with the missing one named in `err`.
  bool load(void* lib, std::string& err) {
    return symbol(lib, "fmi2Instantiate", instantiate, err) && symbol(lib, "fmi2FreeInstance", freeInstance, err) &&
           symbol(lib, "fmi2SetupExperiment", setupExperiment, err) &&
           symbol(lib, "fmi2EnterInitializationMode", enterInitializationMode, err) &&
           symbol(lib, "fmi2ExitInitializationMode", exitInitializationMode, err) &&
           symbol(lib, "fmi2Terminate", terminate, err) && symbol(lib, "fmi2SetReal", setReal, err) &&
           symbol(lib, "fmi2SetInteger", setInteger, err) && symbol(lib, "fmi2SetBoolean", setBoolean, err) &&
           symbol(lib, "fmi2SetString", setString, err) && symbol(lib, "fmi2GetReal", getReal, err) &&
           symbol(lib, "fmi2GetInteger", getInteger, err) && symbol(lib, "fmi2GetBoolean", getBoolean, err) &&
           symbol(lib, "fmi2DoStep", doStep, err) && symbol(lib, "fmi2GetRealStatus", getRealStatus, err) &&
           symbol(lib, "fmi2GetBooleanStatus", getBooleanStatus, err);
  }
};

// The FMI 3.0 Co-Simulation entry points an importer calls (Enumerations through Int64).
struct Fmi3Api {
  fmi3InstantiateCoSimulationTYPE* instantiate = nullptr;
  fmi3FreeInstanceTYPE* freeInstance = nullptr;
  fmi3EnterInitializationModeTYPE* enterInitializationMode = nullptr;
  fmi3ExitInitializationModeTYPE* exitInitializationMode = nullptr;
  fmi3TerminateTYPE* terminate = nullptr;
  fmi3SetFloat64TYPE* setFloat64 = nullptr;
  fmi3SetInt32TYPE* setInt32 = nullptr;
  fmi3SetInt64TYPE* setInt64 = nullptr;
  fmi3SetBooleanTYPE* setBoolean = nullptr;
  fmi3GetFloat64TYPE* getFloat64 = nullptr;
  fmi3GetInt32TYPE* getInt32 = nullptr;
  fmi3GetInt64TYPE* getInt64 = nullptr;
  fmi3GetBooleanTYPE* getBoolean = nullptr;
  fmi3DoStepTYPE* doStep = nullptr;

  bool load(void* lib, std::string& err) {
    return symbol(lib, "fmi3InstantiateCoSimulation", instantiate, err) &&
           symbol(lib, "fmi3FreeInstance", freeInstance, err) &&
           symbol(lib, "fmi3EnterInitializationMode", enterInitializationMode, err) &&
           symbol(lib, "fmi3ExitInitializationMode", exitInitializationMode, err) &&
           symbol(lib, "fmi3Terminate", terminate, err) && symbol(lib, "fmi3SetFloat64", setFloat64, err) &&
           symbol(lib, "fmi3SetInt32", setInt32, err) && symbol(lib, "fmi3SetInt64", setInt64, err) &&
           symbol(lib, "fmi3SetBoolean", setBoolean, err) && symbol(lib, "fmi3GetFloat64", getFloat64, err) &&
           symbol(lib, "fmi3GetInt32", getInt32, err) && symbol(lib, "fmi3GetInt64", getInt64, err) &&
           symbol(lib, "fmi3GetBoolean", getBoolean, err) && symbol(lib, "fmi3DoStep", doStep, err);
  }
};

}  // namespace fmuimport
