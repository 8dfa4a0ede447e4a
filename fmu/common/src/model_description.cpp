// modelDescription.xml generation, table validation and the deterministic GUID.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <set>
#include <sstream>

#include "instance.hpp"

namespace fmuglue {

namespace {

std::string esc(const std::string& s) {
  std::string o;
  o.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': o += "&amp;"; break;
      case '<': o += "&lt;"; break;
      case '>': o += "&gt;"; break;
      case '"': o += "&quot;"; break;
      case '\'': o += "&apos;"; break;
      default: o += c;
    }
  }
  return o;
}

// Shortest decimal text that reads back to exactly the same double: the fewest significant
// digits, and of %g's exponent form and the plain form with those digits the shorter ("10", not
// "1e+01"; "1e-08" and "1e+05" stay).
std::string num(double v) {
  char buf[40];
  for (int prec = 1; prec <= 17; ++prec) {
    std::snprintf(buf, sizeof buf, "%.*g", prec, v);
    if (std::strtod(buf, nullptr) == v) break;
  }
  std::string best = buf;
  const char* e = std::strchr(buf, 'e');
  if (e) {
    const int exp10 = std::atoi(e + 1);
    if (exp10 >= 0 && exp10 < 17) {  // an integer-valued number: %g shows all its digits at that precision
      std::snprintf(buf, sizeof buf, "%.*g", exp10 + 1, v);
      if (std::strtod(buf, nullptr) == v && std::strlen(buf) <= best.size()) best = buf;
    }
  }
  return best;
}

struct BaseUnit {
  const char* name;
  int kg, m, s, rad;
};
const BaseUnit kUnits[] = {
    {"m", 0, 1, 0, 0},        {"kg", 1, 0, 0, 0},        {"s", 0, 0, 1, 0},         {"rad", 0, 0, 0, 1},
    {"N", 1, 1, -2, 0},       {"N.m", 1, 2, -2, 0},      {"N.m/rad", 1, 2, -2, -1}, {"N.m.s/rad", 1, 2, -1, -1},
    {"rad/s", 0, 0, -1, 1},   {"rad/s2", 0, 0, -2, 1},   {"m/s", 0, 1, -1, 0},      {"m/s2", 0, 1, -2, 0},
    {"kg.m2", 1, 2, 0, 0},    {"1/s", 0, 0, -1, 0},      {"s-1", 0, 0, -1, 0},      {"Hz", 0, 0, -1, 0},
    {"N/m", 1, 0, -2, 0},     {"N.s/m", 1, 0, -1, 0},    {"N/rad", 1, 1, -2, -1},   {"N.m.s", 1, 2, -1, 0},
    {"m/rad", 0, 1, 0, -1},   {"1/rad", 0, 0, 0, -1},    {"J", 1, 2, -2, 0},        {"W", 1, 2, -3, 0},
    {"1", 0, 0, 0, 0},  // dimensionless (a ratio, a gain)
};
const BaseUnit* baseUnit(const std::string& unit) {
  for (const auto& k : kUnits)
    if (unit == k.name) return &k;
  return nullptr;
}

// Display units offered next to a unit (value in display unit = factor * value in unit); the
// variables of that unit show the first one by default (displayUnit attribute): angles in degrees.
struct DisplayUnit {
  const char* unit;
  const char* name;
  double factor;
};
constexpr double kDegPerRad = 57.295779513082323;  // 180 / pi
const DisplayUnit kDisplayUnits[] = {
    {"rad", "deg", kDegPerRad}, {"rad/s", "deg/s", kDegPerRad}, {"rad/s2", "deg/s2", kDegPerRad},
};
const DisplayUnit* displayUnit(const std::string& unit) {
  for (const auto& d : kDisplayUnits)
    if (unit == d.unit) return &d;
  return nullptr;
}

// generationDateAndTime: SOURCE_DATE_EPOCH (reproducible builds) or the time of generation, UTC.
std::string generationDateAndTime() {
  std::time_t t = std::time(nullptr);
  if (const char* sde = std::getenv("SOURCE_DATE_EPOCH")) {
    char* end = nullptr;
    const long long v = std::strtoll(sde, &end, 10);
    if (end != sde && *end == '\0' && v >= 0) t = static_cast<std::time_t>(v);
  }
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));  // the generator is single-threaded
  return buf;
}


bool hasStart(const Variable& v) {
  if (v.causality == Causality::Independent) return false;
  if (v.causality == Causality::Input) return true;
  Initial i = effectiveInitial(v);
  return i == Initial::Exact || i == Initial::Approx;
}

// <UnitDefinitions>: every unit of a Real variable with its SI base unit and display unit (the
// same element in FMI 2.0 and 3.0).
std::string unitDefinitions(const ModelInfo& info) {
  std::ostringstream o;
  std::set<std::string> units;
  for (const auto& v : info.variables)
    if (v.type == Type::Real && !v.unit.empty()) units.insert(v.unit);
  if (!units.empty()) {
    o << "  <UnitDefinitions>\n";
    for (const auto& u : units) {
      const BaseUnit* bu = baseUnit(u);  // validateModelInfo: every unit is known
      o << "    <Unit name=\"" << esc(u) << "\"><BaseUnit";
      if (bu->kg) o << " kg=\"" << bu->kg << "\"";
      if (bu->m) o << " m=\"" << bu->m << "\"";
      if (bu->s) o << " s=\"" << bu->s << "\"";
      if (bu->rad) o << " rad=\"" << bu->rad << "\"";
      o << "/>";
      if (const DisplayUnit* du = displayUnit(u))
        o << "<DisplayUnit name=\"" << du->name << "\" factor=\"" << num(du->factor) << "\"/>";
      o << "</Unit>\n";
    }
    o << "  </UnitDefinitions>\n";
  }

  return o.str();
}

// <LogCategories>: the glue's and the model's; `api` names the function family (fmi2 / fmi3).
std::string logCategories(const ModelInfo& info, const char* api) {
  std::ostringstream o;
  o << "  <LogCategories>\n"
       "    <Category name=\"logEvents\" description=\"Discrete events (phase changes, contact changes, faults)\"/>\n"
       "    <Category name=\"logStatusWarning\" description=\"Warnings\"/>\n"
       "    <Category name=\"logStatusDiscard\" description=\"Discarded steps\"/>\n"
       "    <Category name=\"logStatusError\" description=\"Errors (illegal calls, invalid values)\"/>\n"
       "    <Category name=\"logStatusFatal\" description=\"Fatal errors\"/>\n"
       "    <Category name=\"logCalls\" description=\"Every " << api << " function call\"/>\n";
  for (const auto& c : info.extra_log_categories)
    o << "    <Category name=\"" << esc(c.name) << "\" description=\"" << esc(c.description) << "\"/>\n";
  o << "  </LogCategories>\n";

  return o.str();
}

std::string defaultExperiment(const ModelInfo& info) {
  std::ostringstream o;
  const auto& de = info.default_experiment;
  o << "  <DefaultExperiment startTime=\"" << num(de.start_time) << "\" stopTime=\"" << num(de.stop_time) << "\"";
  if (de.tolerance > 0.0) o << " tolerance=\"" << num(de.tolerance) << "\"";
  o << " stepSize=\"" << num(de.step_size) << "\"/>\n";

  return o.str();
}

// The XML with a given GUID string (the GUID itself is a hash of the XML with an empty GUID and
// no generation date, so that it identifies the model, not the build).
std::string xmlWithGuid(const ModelInfo& info, const std::string& guid,
                        const std::vector<std::string>& source_files = {}, const std::string& generated = "") {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o << "<fmiModelDescription fmiVersion=\"2.0\" modelName=\"" << esc(info.model_name) << "\" guid=\"" << guid
    << "\"";
  if (!info.description.empty()) o << "\n  description=\"" << esc(info.description) << "\"";
  if (!info.author.empty()) o << "\n  author=\"" << esc(info.author) << "\"";
  if (!info.version.empty()) o << "\n  version=\"" << esc(info.version) << "\"";
  if (!info.copyright.empty()) o << "\n  copyright=\"" << esc(info.copyright) << "\"";
  if (!info.license.empty()) o << "\n  license=\"" << esc(info.license) << "\"";
  o << "\n  generationTool=\"anklehip fmuglue " << kGlueInterfaceVersion << "\"";
  if (!generated.empty()) o << "\n  generationDateAndTime=\"" << generated << "\"";
  o << "\n  variableNamingConvention=\"structured\" numberOfEventIndicators=\"0\">\n";
  o << "  <CoSimulation modelIdentifier=\"" << esc(info.model_name) << "\" needsExecutionTool=\"false\""
    << " canHandleVariableCommunicationStepSize=\"" << (info.can_handle_variable_step ? "true" : "false") << "\""
    << " canInterpolateInputs=\"false\" maxOutputDerivativeOrder=\"0\" canRunAsynchronuously=\"false\""
    << " canBeInstantiatedOnlyOncePerProcess=\"false\" canNotUseMemoryManagementFunctions=\"true\""
    << " canGetAndSetFMUstate=\"true\" canSerializeFMUstate=\"true\" providesDirectionalDerivative=\"false\"";
  if (source_files.empty()) {
    o << "/>\n";
  } else {
    o << ">\n    <SourceFiles>\n";
    for (const auto& f : source_files) o << "      <File name=\"" << esc(f) << "\"/>\n";
    o << "    </SourceFiles>\n  </CoSimulation>\n";
  }

  o << unitDefinitions(info);

  if (!info.enumerations.empty()) {
    o << "  <TypeDefinitions>\n";
    for (const auto& e : info.enumerations) {
      o << "    <SimpleType name=\"" << esc(e.name) << "\" description=\"" << esc(e.description) << "\">\n"
        << "      <Enumeration>\n";
      for (const auto& it : e.items)
        o << "        <Item name=\"" << esc(it.name) << "\" value=\"" << it.value << "\" description=\""
          << esc(it.description) << "\"/>\n";
      o << "      </Enumeration>\n    </SimpleType>\n";
    }
    o << "  </TypeDefinitions>\n";
  }

  o << logCategories(info, "fmi2");
  o << defaultExperiment(info);

  o << "  <ModelVariables>\n";
  int index = 0;
  for (const auto& v : info.variables) {
    ++index;
    o << "    <!-- index " << index << " -->\n";
    o << "    <ScalarVariable name=\"" << esc(v.name) << "\" valueReference=\"" << v.vr << "\" description=\""
      << esc(v.description) << "\" causality=\"" << xmlName(v.causality) << "\" variability=\""
      << xmlName(v.variability) << "\"";
    if (v.initial != Initial::Default && v.causality != Causality::Input && v.causality != Causality::Independent)
      o << " initial=\"" << xmlName(v.initial) << "\"";
    o << ">\n      ";
    bool st = hasStart(v);
    switch (v.type) {
      case Type::Real:
        o << "<Real";
        if (!v.unit.empty()) o << " unit=\"" << esc(v.unit) << "\"";
        if (const DisplayUnit* du = displayUnit(v.unit)) o << " displayUnit=\"" << du->name << "\"";
        if (!std::isnan(v.min)) o << " min=\"" << num(v.min) << "\"";
        if (!std::isnan(v.max)) o << " max=\"" << num(v.max) << "\"";
        if (st) o << " start=\"" << num(v.start) << "\"";
        o << "/>";
        break;
      case Type::Integer:
        o << "<" << xmlTypeName(v);
        if (!v.enumeration.empty()) o << " declaredType=\"" << esc(v.enumeration) << "\"";
        if (!std::isnan(v.min)) o << " min=\"" << static_cast<long long>(v.min) << "\"";
        if (!std::isnan(v.max)) o << " max=\"" << static_cast<long long>(v.max) << "\"";
        if (st) o << " start=\"" << static_cast<long long>(v.start) << "\"";
        o << "/>";
        break;
      case Type::Boolean:
        o << "<Boolean";
        if (st) o << " start=\"" << (v.start != 0.0 ? "true" : "false") << "\"";
        o << "/>";
        break;
      case Type::String:
        o << "<String";
        if (st) o << " start=\"" << esc(v.start_string) << "\"";
        o << "/>";
        break;
    }
    o << "\n    </ScalarVariable>\n";
  }
  o << "  </ModelVariables>\n";

  o << "  <ModelStructure>\n";
  // The knowns of initialization mode (FMI 2.0.4 section 2.2.8) are the inputs and the variables
  // with initial="exact" (parameters). An initial unknown depends on every parameter (a superset
  // of the true set costs an importer nothing: parameters are never connected) and on the inputs
  // its Variable::initial_inputs names, no other.
  std::map<std::string, int> input_index;
  std::vector<int> param_indices;
  index = 0;
  for (const auto& v : info.variables) {
    ++index;
    if (v.causality == Causality::Input) input_index[v.name] = index;
    if (v.causality == Causality::Parameter && effectiveInitial(v) == Initial::Exact) param_indices.push_back(index);
  }
  auto initial_dependencies = [&](const Variable& v) {
    std::vector<int> deps = param_indices;
    for (const auto& n : v.initial_inputs) deps.push_back(input_index.at(n));  // validated
    std::sort(deps.begin(), deps.end());
    std::string s;
    for (int d : deps) s += (s.empty() ? "" : " ") + std::to_string(d);
    return s;
  };
  std::ostringstream outs, inits;
  index = 0;
  for (const auto& v : info.variables) {
    ++index;
    Initial ini = effectiveInitial(v);
    if (v.causality == Causality::Output) {
      outs << "      <Unknown index=\"" << index << "\"" << (info.outputs_depend_on_inputs ? "" : " dependencies=\"\"")
           << "/>\n";
    }
    if ((v.causality == Causality::Output && (ini == Initial::Approx || ini == Initial::Calculated)) ||
        v.causality == Causality::CalculatedParameter)
      inits << "      <Unknown index=\"" << index << "\" dependencies=\"" << initial_dependencies(v) << "\"/>\n";
  }
  if (!outs.str().empty()) o << "    <Outputs>\n" << outs.str() << "    </Outputs>\n";
  if (!inits.str().empty()) o << "    <InitialUnknowns>\n" << inits.str() << "    </InitialUnknowns>\n";
  o << "  </ModelStructure>\n";
  o << "</fmiModelDescription>\n";
  return o.str();
}


// The FMI 3.0 Co-Simulation description of the same table (modelDescriptionXml3).
const char* xmlName3(const Variable& v) {
  switch (v.type) {
    case Type::Real: return "Float64";
    case Type::Integer: return v.enumeration.empty() ? "Int32" : "Enumeration";
    case Type::Boolean: return "Boolean";
    case Type::String: return "String";
  }
  return "?";
}

// The elements of an array variable (validated: they exist and are Real).
std::vector<const Variable*> arrayElements(const ModelInfo& info, const ArrayVariable& a) {
  std::vector<const Variable*> out;
  for (fmi2ValueReference r : a.elements) {
    auto it = std::find_if(info.variables.begin(), info.variables.end(), [&](const Variable& v) { return v.vr == r; });
    out.push_back(it == info.variables.end() ? nullptr : &*it);
  }
  return out;
}

// scheduled: the Scheduled Execution variant (modelDescriptionXmlSE), else Co-Simulation.
std::string xml3(const ModelInfo& info, const std::string& token, const std::string& generated,
                 bool scheduled = false) {
  std::ostringstream o;
  o << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  o << "<fmiModelDescription fmiVersion=\"3.0\" modelName=\"" << esc(info.model_name) << "\" instantiationToken=\""
    << token << "\"";
  if (!info.description.empty()) o << "\n  description=\"" << esc(info.description) << "\"";
  if (!info.author.empty()) o << "\n  author=\"" << esc(info.author) << "\"";
  if (!info.version.empty()) o << "\n  version=\"" << esc(info.version) << "\"";
  if (!info.copyright.empty()) o << "\n  copyright=\"" << esc(info.copyright) << "\"";
  if (!info.license.empty()) o << "\n  license=\"" << esc(info.license) << "\"";
  o << "\n  generationTool=\"anklehip fmuglue " << kGlueInterfaceVersion << "\"";
  if (!generated.empty()) o << "\n  generationDateAndTime=\"" << generated << "\"";
  o << "\n  variableNamingConvention=\"structured\">\n";
  if (scheduled) {
    o << "  <ScheduledExecution modelIdentifier=\"" << esc(info.model_name) << "\" needsExecutionTool=\"false\""
      << " canBeInstantiatedOnlyOncePerProcess=\"false\" canGetAndSetFMUState=\"true\" canSerializeFMUState=\"true\""
      << " providesDirectionalDerivatives=\"false\" providesAdjointDerivatives=\"false\""
      << " providesPerElementDependencies=\"false\"/>\n";
  } else {
  o << "  <CoSimulation modelIdentifier=\"" << esc(info.model_name) << "\" needsExecutionTool=\"false\""
    << " canBeInstantiatedOnlyOncePerProcess=\"false\" canGetAndSetFMUState=\"true\" canSerializeFMUState=\"true\""
    << " providesDirectionalDerivatives=\"false\" providesAdjointDerivatives=\"false\""
    << " providesPerElementDependencies=\"false\""
    << " canHandleVariableCommunicationStepSize=\"" << (info.can_handle_variable_step ? "true" : "false") << "\"";
  if (info.fixed_internal_step > 0.0) o << " fixedInternalStepSize=\"" << num(info.fixed_internal_step) << "\"";
  o << " maxOutputDerivativeOrder=\"0\" providesIntermediateUpdate=\"false\" mightReturnEarlyFromDoStep=\"false\""
    << " canReturnEarlyAfterIntermediateUpdate=\"false\" hasEventMode=\"false\""
    << " providesEvaluateDiscreteStates=\"false\"/>\n";
  }
  o << unitDefinitions(info);
  if (!info.enumerations.empty()) {
    o << "  <TypeDefinitions>\n";
    for (const auto& e : info.enumerations) {
      o << "    <EnumerationType name=\"" << esc(e.name) << "\" description=\"" << esc(e.description) << "\">\n";
      for (const auto& it : e.items)
        o << "      <Item name=\"" << esc(it.name) << "\" value=\"" << it.value << "\" description=\""
          << esc(it.description) << "\"/>\n";
      o << "    </EnumerationType>\n";
    }
    o << "  </TypeDefinitions>\n";
  }
  o << logCategories(info, "fmi3");
  o << defaultExperiment(info);

  o << "  <ModelVariables>\n";
  o << "    <Float64 name=\"time\" valueReference=\"" << kTimeValueReference
    << "\" description=\"Simulation time\" causality=\"independent\" variability=\"continuous\"/>\n";
  // Scheduled Execution: the input clock of the one model partition, and every input and output
  // clocked by it (clocked variables are discrete: they change only at the clock's ticks).
  const ScheduledClock& clock = info.clock;
  if (scheduled)
    o << "    <Clock name=\"" << esc(clock.name) << "\" valueReference=\"" << clock.vr << "\" description=\""
      << esc(clock.description) << "\" causality=\"input\" variability=\"discrete\" intervalVariability=\"constant\""
      << " intervalDecimal=\"" << num(clock.interval) << "\" priority=\"0\"/>\n";
  auto clocked = [&](Causality c) { return scheduled && (c == Causality::Input || c == Causality::Output); };
  for (const auto& v : info.variables) {
    const char* tag = xmlName3(v);
    o << "    <" << tag << " name=\"" << esc(v.name) << "\" valueReference=\"" << v.vr << "\" description=\""
      << esc(v.description) << "\" causality=\"" << xmlName(v.causality) << "\" variability=\""
      << (clocked(v.causality) ? "discrete" : xmlName(v.variability)) << "\"";
    if (clocked(v.causality)) o << " clocks=\"" << clock.vr << "\"";
    if (v.initial != Initial::Default && v.causality != Causality::Input && v.causality != Causality::Independent)
      o << " initial=\"" << xmlName(v.initial) << "\"";
    const bool st = hasStart(v);
    switch (v.type) {
      case Type::Real:
        if (!v.unit.empty()) o << " unit=\"" << esc(v.unit) << "\"";
        if (const DisplayUnit* du = displayUnit(v.unit)) o << " displayUnit=\"" << du->name << "\"";
        if (!std::isnan(v.min)) o << " min=\"" << num(v.min) << "\"";
        if (!std::isnan(v.max)) o << " max=\"" << num(v.max) << "\"";
        if (st) o << " start=\"" << num(v.start) << "\"";
        o << "/>\n";
        break;
      case Type::Integer:
        if (!v.enumeration.empty()) o << " declaredType=\"" << esc(v.enumeration) << "\"";
        if (!std::isnan(v.min)) o << " min=\"" << static_cast<long long>(v.min) << "\"";
        if (!std::isnan(v.max)) o << " max=\"" << static_cast<long long>(v.max) << "\"";
        if (st) o << " start=\"" << static_cast<long long>(v.start) << "\"";
        o << "/>\n";
        break;
      case Type::Boolean:
        if (st) o << " start=\"" << (v.start != 0.0 ? "true" : "false") << "\"";
        o << "/>\n";
        break;
      case Type::String:
        if (st) o << ">\n      <Start value=\"" << esc(v.start_string) << "\"/>\n    </String>\n";
        else o << "/>\n";
        break;
    }
  }
  // The arrays: <Float64> with a <Dimension> per dimension; the rest is the elements' (validated
  // to agree), the start values in row-major order.
  for (const auto& a : info.arrays) {
    const auto el = arrayElements(info, a);
    const Variable& e = *el.front();
    o << "    <Float64 name=\"" << esc(a.name) << "\" valueReference=\"" << a.vr << "\" description=\""
      << esc(a.description) << "\" causality=\"" << xmlName(e.causality) << "\" variability=\""
      << (clocked(e.causality) ? "discrete" : xmlName(e.variability)) << "\"";
    if (clocked(e.causality)) o << " clocks=\"" << clock.vr << "\"";
    if (e.initial != Initial::Default && e.causality != Causality::Input) o << " initial=\"" << xmlName(e.initial) << "\"";
    if (!e.unit.empty()) o << " unit=\"" << esc(e.unit) << "\"";
    if (const DisplayUnit* du = displayUnit(e.unit)) o << " displayUnit=\"" << du->name << "\"";
    if (!std::isnan(e.min)) o << " min=\"" << num(e.min) << "\"";
    if (!std::isnan(e.max)) o << " max=\"" << num(e.max) << "\"";
    if (hasStart(e)) {
      o << " start=\"";
      for (size_t k = 0; k < el.size(); ++k) o << (k ? " " : "") << num(el[k]->start);
      o << "\"";
    }
    o << ">\n";
    for (int d : a.dimensions) o << "      <Dimension start=\"" << d << "\"/>\n";
    o << "    </Float64>\n";
  }
  o << "  </ModelVariables>\n";

  // <ModelStructure>: as the FMI 2.0 description's (xmlWithGuid), with value references.
  std::map<std::string, fmi2ValueReference> input_vr;
  std::vector<fmi2ValueReference> param_vrs;
  for (const auto& v : info.variables) {
    if (v.causality == Causality::Input) input_vr[v.name] = v.vr;
    if (v.causality == Causality::Parameter && effectiveInitial(v) == Initial::Exact) param_vrs.push_back(v.vr);
  }
  o << "  <ModelStructure>\n";
  // (vr, its variable or an array's first element, the initial inputs): the scalars, then the arrays
  struct Entry {
    fmi2ValueReference vr;
    const Variable* v;
    std::set<std::string> initial_inputs;
  };
  std::vector<Entry> entries;
  for (const auto& v : info.variables) entries.push_back({v.vr, &v, {v.initial_inputs.begin(), v.initial_inputs.end()}});
  for (const auto& a : info.arrays) {
    Entry e{a.vr, arrayElements(info, a).front(), {}};
    for (const Variable* x : arrayElements(info, a)) e.initial_inputs.insert(x->initial_inputs.begin(), x->initial_inputs.end());
    entries.push_back(std::move(e));
  }
  for (const auto& e : entries)
    if (e.v->causality == Causality::Output)
      o << "    <Output valueReference=\"" << e.vr << "\"" << (info.outputs_depend_on_inputs ? "" : " dependencies=\"\"")
        << "/>\n";
  for (const auto& e : entries) {
    const Variable& v = *e.v;
    const Initial ini = effectiveInitial(v);
    // clocked outputs are no initial unknowns (FMI 3.0 section 2.4.8.3): they have values at ticks only
    if (!((v.causality == Causality::Output && !clocked(v.causality) &&
           (ini == Initial::Approx || ini == Initial::Calculated)) ||
          v.causality == Causality::CalculatedParameter))
      continue;
    std::vector<fmi2ValueReference> deps = param_vrs;
    for (const auto& n : e.initial_inputs) deps.push_back(input_vr.at(n));  // validated
    std::sort(deps.begin(), deps.end());
    o << "    <InitialUnknown valueReference=\"" << e.vr << "\" dependencies=\"";
    for (size_t k = 0; k < deps.size(); ++k) o << (k ? " " : "") << deps[k];
    o << "\"/>\n";
  }
  o << "  </ModelStructure>\n";
  o << "</fmiModelDescription>\n";
  return o.str();
}
}  // namespace

Initial effectiveInitial(const Variable& v) {
  if (v.causality == Causality::Input) return Initial::Exact;  // inputs carry a start value, no attribute
  if (v.causality == Causality::Independent) return Initial::Calculated;
  if (v.initial != Initial::Default) return v.initial;
  switch (v.causality) {
    case Causality::Parameter: return Initial::Exact;
    case Causality::CalculatedParameter: return Initial::Calculated;
    default: return v.variability == Variability::Constant ? Initial::Exact : Initial::Calculated;
  }
}

std::string validateModelInfo(const ModelInfo& info) {
  std::ostringstream err;
  if (info.model_name.empty()) err << "model_name is empty\n";
  for (char ch : info.model_name)
    if (!(std::isalnum(static_cast<unsigned char>(ch)) || ch == '_')) {
      err << "model_name \"" << info.model_name << "\" must be a C identifier\n";
      break;
    }
  std::set<std::string> types;
  for (const auto& e : info.enumerations) {
    if (!types.insert(e.name).second) err << "enumeration \"" << e.name << "\": duplicate name\n";
    if (e.items.empty()) err << "enumeration \"" << e.name << "\": no items\n";
    std::set<std::string> item_names;
    std::set<int> item_values;
    for (const auto& it : e.items)
      if (!item_names.insert(it.name).second || !item_values.insert(it.value).second)
        err << "enumeration \"" << e.name << "\": item " << it.name << " = " << it.value << " repeats a name or value\n";
  }
  std::set<std::string> names;
  std::set<fmi2ValueReference> vrs;
  for (const auto& v : info.variables) {
    std::string w = "variable \"" + v.name + "\": ";
    if (v.name.empty()) err << "a variable has an empty name\n";
    if (!names.insert(v.name).second) err << w << "duplicate name\n";
    if (!vrs.insert(v.vr).second) err << w << "duplicate value reference " << v.vr << "\n";
    if (v.vr > (1u << 20)) err << w << "value reference " << v.vr << " is too large (max 2^20)\n";
    if (v.description.empty()) err << w << "missing description\n";
    if (v.type != Type::Real && v.variability == Variability::Continuous)
      err << w << "only Real variables can be continuous\n";
    if (v.type != Type::Real && !v.unit.empty()) err << w << "only Real variables have units\n";
    if (!v.enumeration.empty()) {
      auto e = std::find_if(info.enumerations.begin(), info.enumerations.end(),
                            [&](const EnumerationType& x) { return x.name == v.enumeration; });
      if (v.type != Type::Integer) err << w << "only Integer variables have an enumeration\n";
      if (e == info.enumerations.end()) {
        err << w << "enumeration \"" << v.enumeration << "\" is not in ModelInfo::enumerations\n";
      } else if (hasStart(v) && std::none_of(e->items.begin(), e->items.end(),
                                             [&](const EnumerationItem& it) { return it.value == v.start; })) {
        err << w << "start " << v.start << " is no item of enumeration \"" << v.enumeration << "\"\n";
      }
    }
    if (!v.unit.empty() && !baseUnit(v.unit))
      err << w << "unit \"" << v.unit << "\" has no base unit in model_description.cpp's kUnits\n";
    bool okVar = true;
    switch (v.causality) {
      case Causality::Parameter:
      case Causality::CalculatedParameter:
        okVar = v.variability == Variability::Fixed || v.variability == Variability::Tunable;
        break;
      case Causality::Input: okVar = v.variability == Variability::Discrete || v.variability == Variability::Continuous; break;
      case Causality::Output: okVar = v.variability != Variability::Fixed && v.variability != Variability::Tunable; break;
      case Causality::Independent: okVar = v.variability == Variability::Continuous && v.type == Type::Real; break;
      case Causality::Local: okVar = true; break;
    }
    if (!okVar) err << w << "illegal causality/variability combination\n";
    if (v.initial != Initial::Default) {
      bool okIni = true;
      switch (v.causality) {
        case Causality::Parameter: okIni = v.initial == Initial::Exact; break;
        case Causality::CalculatedParameter: okIni = v.initial != Initial::Exact; break;
        case Causality::Input:
        case Causality::Independent: okIni = false; break;
        default:
          okIni = v.variability == Variability::Constant ? v.initial == Initial::Exact : true;
      }
      if (!okIni) err << w << "illegal initial attribute for this causality/variability\n";
    }
    if ((v.type == Type::Real || v.type == Type::Integer) && hasStart(v)) {
      if (!std::isfinite(v.start)) err << w << "start value is not finite\n";
      if (!std::isnan(v.min) && v.start < v.min) err << w << "start " << v.start << " < min " << v.min << "\n";
      if (!std::isnan(v.max) && v.start > v.max) err << w << "start " << v.start << " > max " << v.max << "\n";
    }
    if (!std::isnan(v.min) && !std::isnan(v.max) && v.min > v.max) err << w << "min > max\n";
    if (!v.initial_inputs.empty() && v.causality != Causality::Output)
      err << w << "only outputs have initial_inputs\n";
    for (const auto& n : v.initial_inputs) {
      auto it = std::find_if(info.variables.begin(), info.variables.end(), [&](const Variable& x) { return x.name == n; });
      if (it == info.variables.end() || it->causality != Causality::Input)
        err << w << "initial_inputs names \"" << n << "\", which is not an input\n";
    }
  }
  // FMI 3.0 arrays: views of Real inputs or outputs that agree in everything but name and start.
  for (const auto& a : info.arrays) {
    std::string w = "array \"" + a.name + "\": ";
    if (a.name.empty()) err << "an array has an empty name\n";
    if (!names.insert(a.name).second) err << w << "duplicate name\n";
    if (!vrs.insert(a.vr).second) err << w << "duplicate value reference " << a.vr << "\n";
    if (a.vr > (1u << 20)) err << w << "value reference " << a.vr << " is too large (max 2^20)\n";
    if (a.description.empty()) err << w << "missing description\n";
    size_t n = a.dimensions.empty() ? 0 : 1;
    for (int d : a.dimensions) {
      if (d < 1) err << w << "dimension " << d << " < 1\n";
      n *= static_cast<size_t>(std::max(d, 0));
    }
    if (n == 0 || n != a.elements.size()) {
      err << w << a.elements.size() << " elements for dimensions of " << n << " values\n";
      continue;
    }
    const auto el = arrayElements(info, a);
    if (std::find(el.begin(), el.end(), nullptr) != el.end()) {
      err << w << "an element's value reference is no variable of the table\n";
      continue;
    }
    const Variable& f = *el.front();
    for (const Variable* x : el) {
      if (x->type != Type::Real || (x->causality != Causality::Input && x->causality != Causality::Output) ||
          x->causality != f.causality || x->variability != f.variability || x->initial != f.initial ||
          x->unit != f.unit || !(x->min == f.min || (std::isnan(x->min) && std::isnan(f.min))) ||
          !(x->max == f.max || (std::isnan(x->max) && std::isnan(f.max))))
        err << w << "element " << x->name << " is not a Real input or output like the first element\n";
    }
  }
  if (info.clock.interval != 0.0) {
    const ScheduledClock& c = info.clock;
    if (!(c.interval > 0.0 && std::isfinite(c.interval))) err << "clock \"" << c.name << "\": interval must be > 0\n";
    if (c.name.empty() || c.description.empty()) err << "the clock needs a name and a description\n";
    if (!names.insert(c.name).second) err << "clock \"" << c.name << "\": duplicate name\n";
    if (!vrs.insert(c.vr).second) err << "clock \"" << c.name << "\": duplicate value reference " << c.vr << "\n";
    if (c.vr > (1u << 20)) err << "clock \"" << c.name << "\": value reference too large (max 2^20)\n";
    auto p = std::find_if(info.variables.begin(), info.variables.end(),
                          [&](const Variable& v) { return v.name == c.period_parameter; });
    if (!c.period_parameter.empty() && (p == info.variables.end() || p->type != Type::Real ||
                                        p->causality != Causality::Parameter))
      err << "clock \"" << c.name << "\": period_parameter \"" << c.period_parameter << "\" is no Real parameter\n";
    for (const auto& v : info.variables)
      if (v.causality == Causality::Output && v.variability != Variability::Discrete)
        err << "variable \"" << v.name << "\": a clocked output (Scheduled Execution) must be discrete\n";
  }
  return err.str();
}

std::string modelGuid(const ModelInfo& info) {
  std::string body = xmlWithGuid(info, "");
  std::uint64_t a = fnv1a64(body.data(), body.size());
  std::uint64_t b = fnv1a64(body.data(), body.size(), a ^ 0x9e3779b97f4a7c15ull);
  char buf[64];
  std::snprintf(buf, sizeof buf, "{%08x-%04x-%04x-%04x-%012llx}", static_cast<unsigned>(a >> 32),
                static_cast<unsigned>((a >> 16) & 0xffff), static_cast<unsigned>(a & 0xffff),
                static_cast<unsigned>(b >> 48), static_cast<unsigned long long>(b & 0xffffffffffffull));
  return buf;
}

const std::string& thisModelGuid() {
  static const std::string guid = modelGuid(modelInfo());
  return guid;
}

std::string modelDescriptionXml(const ModelInfo& info, const std::vector<std::string>& source_files) {
  return xmlWithGuid(info, modelGuid(info), source_files, generationDateAndTime());
}

std::string modelDescriptionXml3(const ModelInfo& info) {
  return xml3(info, modelGuid(info), generationDateAndTime());
}

std::string modelDescriptionXmlSE(const ModelInfo& info) {
  return xml3(info, modelGuid(info), generationDateAndTime(), true);
}

const char* xmlName(Type t) {
  switch (t) {
    case Type::Real: return "Real";
    case Type::Integer: return "Integer";
    case Type::Boolean: return "Boolean";
    case Type::String: return "String";
  }
  return "?";
}

const char* xmlTypeName(const Variable& v) {
  return v.type == Type::Integer && !v.enumeration.empty() ? "Enumeration" : xmlName(v.type);
}

const char* xmlName(Causality c) {
  switch (c) {
    case Causality::Parameter: return "parameter";
    case Causality::CalculatedParameter: return "calculatedParameter";
    case Causality::Input: return "input";
    case Causality::Output: return "output";
    case Causality::Local: return "local";
    case Causality::Independent: return "independent";
  }
  return "local";
}

const char* xmlName(Variability v) {
  switch (v) {
    case Variability::Constant: return "constant";
    case Variability::Fixed: return "fixed";
    case Variability::Tunable: return "tunable";
    case Variability::Discrete: return "discrete";
    case Variability::Continuous: return "continuous";
  }
  return "continuous";
}

const char* xmlName(Initial i) {
  switch (i) {
    case Initial::Exact: return "exact";
    case Initial::Approx: return "approx";
    case Initial::Calculated: return "calculated";
    default: return "";
  }
}

}  // namespace fmuglue
