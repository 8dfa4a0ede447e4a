// The parameters of a controller FMU from one of the C library's parameter tables (ahc_param_info
// rows: ahc_param_table, ahc_frontal_param_table): one variable per row, value reference
// first + row index, start value from the defaults struct, range from the row; and reading them
// back into a struct; and the checks of a restored state against the variables. Shared by
// AnkleHipController.fmu and AnkleHipController3D.fmu.
#pragma once

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <utility>
#include <vector>

#include "ahc/controller.h"
#include "fmuglue/glue.hpp"

namespace ahcfmu {

using IsTunable = bool (*)(const char* name);

inline void addParamVariables(fmuglue::ModelInfo& m, const ahc_param_info* table, size_t count,
                              fmi2ValueReference first, const void* defaults, IsTunable tunable) {
  using namespace fmuglue;
  for (size_t i = 0; i < count; ++i) {
    const ahc_param_info& p = table[i];
    Variable v;
    v.name = p.name;
    v.vr = first + static_cast<fmi2ValueReference>(i);
    v.type = p.is_int ? Type::Integer : Type::Real;
    v.causality = Causality::Parameter;
    v.variability = tunable(p.name) ? Variability::Tunable : Variability::Fixed;
    v.unit = p.is_int ? "" : p.unit;
    v.description = p.description;
    const char* base = static_cast<const char*>(defaults) + p.offset;
    if (p.is_int) {
      int x;
      std::memcpy(&x, base, sizeof x);
      v.start = x;
    } else {
      std::memcpy(&v.start, base, sizeof(double));
    }
    v.min = std::isfinite(p.min) ? p.min : kNoBound;
    v.max = std::isfinite(p.max) ? p.max : kNoBound;
    m.variables.push_back(v);
  }
}

// Reads the table's variables into the struct at p (only the tunable ones with `only`).
inline void readParamVariables(fmuglue::Context& ctx, const ahc_param_info* table, size_t count,
                               fmi2ValueReference first, void* p, IsTunable only = nullptr) {
  for (size_t i = 0; i < count; ++i) {
    if (only && !only(table[i].name)) continue;
    char* base = static_cast<char*>(p) + table[i].offset;
    const fmi2ValueReference r = first + static_cast<fmi2ValueReference>(i);
    if (table[i].is_int) {
      const int x = ctx.integer(r);
      std::memcpy(base, &x, sizeof x);
    } else {
      const double x = ctx.real(r);
      std::memcpy(base, &x, sizeof x);
    }
  }
}

// The rows of a parameter table whose values differ between p and def, as TOML lines.
inline std::string differingRows(const ahc_param_info* table, size_t count, const void* p, const void* def) {
  std::string s;
  for (size_t i = 0; i < count; ++i) {
    const char* a = static_cast<const char*>(p) + table[i].offset;
    const char* b = static_cast<const char*>(def) + table[i].offset;
    char line[160];
    if (table[i].is_int) {
      int x, y;
      std::memcpy(&x, a, sizeof x);
      std::memcpy(&y, b, sizeof y);
      if (x == y) continue;
      std::snprintf(line, sizeof line, "%s = %d\n", table[i].name, x);
    } else {
      double x, y;
      std::memcpy(&x, a, sizeof x);
      std::memcpy(&y, b, sizeof y);
      if (x == y) continue;
      // The shortest of %.15g / %.17g that reads back exactly.
      std::snprintf(line, sizeof line, "%.15g", x);
      const char* fmt = std::strtod(line, nullptr) == x ? "%s = %.15g\n" : "%s = %.17g\n";
      std::snprintf(line, sizeof line, fmt, table[i].name, x);
    }
    s += line;
  }
  return s;
}

// The first row of a parameter table whose value differs bit for bit between a (a restored state's
// copy) and b (the instance's variables), as "name = x in the state, y in the instance"; "" if none.
inline std::string firstDifferingParam(const ahc_param_info* table, size_t count, const void* a, const void* b) {
  for (size_t i = 0; i < count; ++i) {
    const char* pa = static_cast<const char*>(a) + table[i].offset;
    const char* pb = static_cast<const char*>(b) + table[i].offset;
    char line[200];
    if (table[i].is_int) {
      int x, y;
      std::memcpy(&x, pa, sizeof x);
      std::memcpy(&y, pb, sizeof y);
      if (x == y) continue;
      std::snprintf(line, sizeof line, "%s = %d in the state, %d in the instance", table[i].name, x, y);
    } else {
      if (std::memcmp(pa, pb, sizeof(double)) == 0) continue;
      double x, y;
      std::memcpy(&x, pa, sizeof x);
      std::memcpy(&y, pb, sizeof y);
      std::snprintf(line, sizeof line, "%s = %.17g in the state, %.17g in the instance", table[i].name, x, y);
    }
    return line;
  }
  return "";
}

// Whether a restored state's output variables are `expected` (value reference and value, Integer
// where isInteger) plus the erect posture of p at its two value references; if not, err names the
// first that differs ("controller state rejected: output VR = x, the controller's state gives y").
template <class IsInteger>
bool restoredOutputsAre(const fmuglue::Context& ctx, std::vector<std::pair<fmi2ValueReference, double>> expected,
                        const ahc_params& p, fmi2ValueReference ankle_erect, fmi2ValueReference hip_erect,
                        IsInteger isInteger, std::string& err) {
  double e1 = 0.0, e2 = 0.0;
  ahc_erect_posture(&p, &e1, &e2);
  expected.emplace_back(ankle_erect, e1);
  expected.emplace_back(hip_erect, e2);
  for (const auto& [r, v] : expected) {
    const double restored = isInteger(r) ? ctx.integer(r) : ctx.real(r);
    if (restored != v) {
      char line[200];
      std::snprintf(line, sizeof line, "controller state rejected: output %u = %.17g, the controller's state gives %.17g",
                    r, restored, v);
      err = line;
      return false;
    }
  }
  return true;
}

// The enumeration "Phase" of both controllers' phase outputs (AHC_PHASE_*).
inline void addPhaseEnumeration(fmuglue::ModelInfo& m) {
  m.enumerations.push_back({"Phase", "Phase of the balance controller (docs/controller.md)",
                            {{"ankle", AHC_PHASE_ANKLE, "ankle strategy"},
                             {"ankle_to_hip", AHC_PHASE_ANKLE_TO_HIP, "transition ankle -> hip"},
                             {"hip", AHC_PHASE_HIP, "hip strategy"},
                             {"hip_to_ankle", AHC_PHASE_HIP_TO_ANKLE, "transition hip -> ankle"}}});
}

// resources/configurations.toml: every named configuration of the C library (ahc_params_named)
// with the parameter values that differ from the defaults, for importers that select a
// configuration by name (anklehip: `controller_config = "paper"`); `more_rows`, when given, adds an
// FMU's own rows per configuration name (the 3D controller's frontal ones), `more_configs` an FMU's
// own configurations after them (the 3D controller's stepping ones). Generated, never edited.
inline std::string configurationsToml(const char* model, std::string (*more_rows)(const char* config) = nullptr,
                                      std::string (*more_configs)() = nullptr) {
  ahc_params def;
  ahc_params_default(&def);
  size_t count = 0;
  const ahc_param_info* table = ahc_param_table(&count);
  std::string s =
      std::string("# Named configurations of ") + model + ": parameter values that differ from the defaults.\n"
      "# Generated from controller_c (ahc_params_named); see documentation/ and docs/controller.md.\n";
  for (size_t c = 0; c < ahc_config_count(); ++c) {
    ahc_params p;
    ahc_params_named(&p, ahc_config_name(c));
    s += std::string("\n[") + ahc_config_name(c) + "]\ndescription = \"" + ahc_config_description(c) + "\"\n";
    s += differingRows(table, count, &p, &def);
    if (more_rows) s += more_rows(ahc_config_name(c));
  }
  if (more_configs) s += more_configs();
  return s;
}

}  // namespace ahcfmu
