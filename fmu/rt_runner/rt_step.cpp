// anklehip_rt_step — native real-time step test of an FMI 2.0 or FMI 3.0 co-simulation FMU (no
// Python).
//
// Loads <fmu-dir>/binaries/linux64/<modelIdentifier>.so from an extracted FMU with dlopen (FMI 3.0:
// binaries/x86_64-linux; on Windows binaries/win64 or x86_64-windows/<modelIdentifier>.dll with
// LoadLibrary: the same program cross-built with mingw-w64 replays a recorded run through the
// Windows binaries, under Wine here; built for aarch64, binaries/aarch64-linux under qemu), reads
// an input CSV (time + input columns by variable name), steps the FMU at a fixed period either
// paced in wall-clock time with absolute deadlines (clock_nanosleep TIMER_ABSTIME on
// CLOCK_MONOTONIC; deadline k = start + k*period, so no drift accumulates) or as fast as possible
// (--fast, for worst-case execution time), measures each fmi2DoStep's execution time and each
// period's wake-up lateness, writes the outputs CSV and prints p50/p99/p99.9/max and the deadline
// misses. Communication points and input values are computed exactly as FMPy's simulate_fmu does
// (t_k = t0 + k*h, linear interpolation of the CSV), so outputs are bit-identical to FMPy's.
// See docs/fmu.md ("Native real-time runner").
#ifdef _WIN32
#include <windows.h>
#else
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "fmi2Functions.h"
#include "fmu_library.hpp"

namespace {

struct Var {
  std::string name, causality, type;
  fmi2ValueReference vr = 0;
};

struct Md {
  bool fmi3 = false;  // fmiVersion 3.0: instantiationToken, Float64/Int32/Enumeration/Boolean elements
  std::string id, guid;
  double stepSize = 0.0;
  std::vector<Var> vars;
};

std::string attr(const std::string& tag, const char* name) {
  std::string key = std::string(" ") + name + "=\"";
  size_t p = tag.find(key);
  if (p == std::string::npos) {  // also accept newline/tab before the attribute
    for (char ws : {'\n', '\t', '\r'}) {
      key[0] = ws;
      p = tag.find(key);
      if (p != std::string::npos) break;
    }
    if (p == std::string::npos) return "";
  }
  p += key.size();
  size_t e = tag.find('"', p);
  return e == std::string::npos ? "" : tag.substr(p, e - p);
}

bool readFile(const std::string& path, std::string& out) {
  std::ifstream f(path, std::ios::binary);
  if (!f) return false;
  std::ostringstream s;
  s << f.rdbuf();
  out = s.str();
  return true;
}

// A tiny tolerant reader of the modelDescription.xml attributes we need.
bool parseMd(const std::string& xml, Md& md, std::string& err) {
  size_t cs = xml.find("<CoSimulation");
  if (cs == std::string::npos) { err = "no <CoSimulation> element"; return false; }
  md.id = attr(xml.substr(cs, xml.find('>', cs) - cs), "modelIdentifier");
  size_t root = xml.find("<fmiModelDescription");
  if (root == std::string::npos) { err = "no <fmiModelDescription>"; return false; }
  const std::string rootTag = xml.substr(root, xml.find('>', root) - root);
  md.fmi3 = attr(rootTag, "fmiVersion").rfind("3", 0) == 0;
  md.guid = attr(rootTag, md.fmi3 ? "instantiationToken" : "guid");
  size_t de = xml.find("<DefaultExperiment");
  if (de != std::string::npos) {
    std::string s = attr(xml.substr(de, xml.find('>', de) - de), "stepSize");
    if (!s.empty()) md.stepSize = std::strtod(s.c_str(), nullptr);
  }
  if (md.fmi3) {
    // FMI 3.0: one element per variable, named by its type. Types as the loop calls them: Real
    // (Float64), Integer (Int32), Enum (Enumeration: fmi3Get/SetInt64), Boolean; others kept by name.
    size_t p = xml.find("<ModelVariables>");
    const size_t end = xml.find("</ModelVariables>");
    while (p != std::string::npos && (p = xml.find('<', p + 1)) < end) {
      if (xml[p + 1] == '/' || xml[p + 1] == '!') continue;
      const size_t e = xml.find('>', p);
      const size_t te = xml.find_first_of(" />\n\t", p + 1);
      const std::string type = xml.substr(p + 1, te - p - 1);
      if (type == "Start" || type == "Dimension" || type == "Alias" || type == "Item") continue;
      const std::string tag = xml.substr(p, e - p);
      if (xml[e - 1] != '/') {  // an element with children: an array (<Dimension>) is skipped, it is
        const size_t close = xml.find("</" + type + ">", e);  // a view of scalars we read (docs/fmu.md)
        if (close != std::string::npos && xml.substr(e, close - e).find("<Dimension") != std::string::npos) {
          p = close;
          continue;
        }
      }
      Var v;
      v.name = attr(tag, "name");
      v.causality = attr(tag, "causality");
      if (v.causality.empty()) v.causality = "local";
      v.vr = static_cast<fmi2ValueReference>(std::strtoul(attr(tag, "valueReference").c_str(), nullptr, 10));
      v.type = type == "Float64" ? "Real" : type == "Int32" ? "Integer" : type == "Enumeration" ? "Enum" : type;
      md.vars.push_back(v);
    }
  } else {
    size_t p = 0;
    while ((p = xml.find("<ScalarVariable", p)) != std::string::npos) {
      size_t e = xml.find('>', p);
      if (e == std::string::npos) break;
      std::string tag = xml.substr(p, e - p);
      Var v;
      v.name = attr(tag, "name");
      v.causality = attr(tag, "causality");
      if (v.causality.empty()) v.causality = "local";
      v.vr = static_cast<fmi2ValueReference>(std::strtoul(attr(tag, "valueReference").c_str(), nullptr, 10));
      size_t t = xml.find('<', e);
      if (t != std::string::npos) {
        size_t te = xml.find_first_of(" />", t + 1);
        v.type = xml.substr(t + 1, te - t - 1);
        if (v.type == "Enumeration") v.type = "Integer";  // FMI 2.0: enumerations go through fmi2Get/SetInteger
      }
      md.vars.push_back(v);
      p = e;
    }
  }
  if (md.id.empty() || md.guid.empty()) { err = "modelIdentifier or guid missing"; return false; }
  return true;
}

void logMessage3(fmi3InstanceEnvironment, fmi3Status status, fmi3String category, fmi3String message) {
  static const char* names[] = {"OK", "Warning", "Discard", "Error", "Fatal"};
  std::fprintf(stderr, "[%s] rt %s: %s\n", status >= 0 && status <= 4 ? names[status] : "?", category ? category : "",
               message ? message : "");
}

void logger(fmi2ComponentEnvironment, fmi2String instance, fmi2Status status, fmi2String category,
            fmi2String message, ...) {
  static const char* names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
  char buf[2048];
  va_list ap;
  va_start(ap, message);
  std::vsnprintf(buf, sizeof buf, message, ap);
  va_end(ap);
  std::fprintf(stderr, "[%s] %s %s: %s\n", status >= 0 && status <= 5 ? names[status] : "?", instance ? instance : "",
               category ? category : "", buf);
}

void splitCsv(const std::string& line, std::vector<std::string>& f) {
  f.clear();
  std::string cur;
  for (char c : line) {
    if (c == ',') { f.push_back(cur); cur.clear(); }
    else if (c != '\r' && c != '\n' && c != '"') cur += c;
  }
  f.push_back(cur);
  for (auto& s : f) {
    size_t a = s.find_first_not_of(' '), b = s.find_last_not_of(' ');
    s = a == std::string::npos ? "" : s.substr(a, b - a + 1);
  }
}

int64_t nowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch()).count();
}

#ifdef _WIN32
// Paced mode needs absolute-deadline sleeps (clock_nanosleep), which this port does not have.
constexpr bool kCanPace = false;
void sleepUntil(int64_t) {}
#else
// Absolute deadline on CLOCK_MONOTONIC, the clock steady_clock reads on Linux.
constexpr bool kCanPace = true;
void sleepUntil(int64_t ns) {
  timespec ts;
  ts.tv_sec = static_cast<time_t>(ns / 1000000000LL);
  ts.tv_nsec = static_cast<long>(ns % 1000000000LL);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) != 0) {}
}
#endif

double pct(std::vector<int64_t> v, double q) {  // nearest-rank percentile, in microseconds
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  size_t k = static_cast<size_t>(std::ceil(q / 100.0 * static_cast<double>(v.size())));
  k = k == 0 ? 0 : k - 1;
  if (k >= v.size()) k = v.size() - 1;
  return static_cast<double>(v[k]) / 1000.0;
}

void usage(const char* a0) {
  std::fprintf(stderr,
               "usage: %s --fmu-dir DIR --input IN.csv [--output OUT.csv] [--step H] [--stop-time T]\n"
               "          [--fast] [--param name=value]... [--timings TIMINGS.csv] [--rt-priority N]\n"
               "          [--mlock] [--log]\n"
               "  DIR      extracted FMI 2.0 or 3.0 FMU (modelDescription.xml, binaries/linux64/<id>.so or\n"
               "           x86_64-linux (aarch64: aarch64-linux); Windows: binaries/win64 or\n"
               "           x86_64-windows/<id>.dll, and --fast is required)\n"
               "  --step   communication step = real-time period [s] (default: DefaultExperiment stepSize)\n"
               "  --fast   do not pace: run as fast as possible (WCET measurement)\n"
               "  --timings  per step: step,time,exec_ns,lateness_ns,miss (miss = 1 when the step's\n"
               "           work ended after the next deadline; lateness and miss are 0 with --fast)\n"
               "Exit status: 0 ok, 1 FMU error or I/O error, 2 usage error.\n",
               a0);
}


}  // namespace

int main(int argc, char** argv) {
  std::string dir, in, out, timings;
  double step = 0.0, stop = NAN;
  bool fast = false, mlock = false, logOn = false;
  int prio = 0;
  std::vector<std::pair<std::string, std::string>> params;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) { usage(argv[0]); std::exit(2); }
      return argv[++i];
    };
    if (a == "--fmu-dir") dir = next();
    else if (a == "--input") in = next();
    else if (a == "--output") out = next();
    else if (a == "--timings") timings = next();
    else if (a == "--step") step = std::strtod(next().c_str(), nullptr);
    else if (a == "--stop-time") stop = std::strtod(next().c_str(), nullptr);
    else if (a == "--fast") fast = true;
    else if (a == "--mlock") mlock = true;
    else if (a == "--log") logOn = true;
    else if (a == "--rt-priority") prio = std::atoi(next().c_str());
    else if (a == "--param") {
      std::string kv = next();
      size_t eq = kv.find('=');
      if (eq == std::string::npos) { usage(argv[0]); return 2; }
      params.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
    } else if (a == "-h" || a == "--help") { usage(argv[0]); return 0; }
    else { std::fprintf(stderr, "error: unknown option %s\n", a.c_str()); usage(argv[0]); return 2; }
  }
  if (dir.empty() || in.empty()) { usage(argv[0]); return 2; }
  if (!fast && !kCanPace) {
    std::fprintf(stderr, "error: paced mode is not available on this platform: use --fast\n");
    return 2;
  }

  std::string xml, err;
  if (!readFile(dir + "/modelDescription.xml", xml)) {
    std::fprintf(stderr, "error: cannot read %s/modelDescription.xml\n", dir.c_str());
    return 1;
  }
  Md md;
  if (!parseMd(xml, md, err)) { std::fprintf(stderr, "error: modelDescription.xml: %s\n", err.c_str()); return 1; }
  if (!(step > 0.0)) step = md.stepSize;
  if (!(step > 0.0)) { std::fprintf(stderr, "error: no --step and no DefaultExperiment stepSize\n"); return 2; }

  // ---- input CSV ----
  std::ifstream fin(in);
  if (!fin) { std::fprintf(stderr, "error: cannot read %s\n", in.c_str()); return 1; }
  std::string line;
  std::vector<std::string> f;
  if (!std::getline(fin, line)) { std::fprintf(stderr, "error: %s is empty\n", in.c_str()); return 1; }
  splitCsv(line, f);
  struct Col { size_t csv; const Var* var; };
  std::vector<Col> cols;
  for (size_t c = 1; c < f.size(); ++c) {
    const Var* v = nullptr;
    for (const auto& x : md.vars)
      if (x.name == f[c]) v = &x;
    if (!v || v->causality != "input") {
      std::fprintf(stderr, "warning: column \"%s\" is not an input of %s; ignored\n", f[c].c_str(), md.id.c_str());
      continue;
    }
    if (v->type != "Real" && v->type != "Integer" && v->type != "Enum" && v->type != "Boolean") {
      std::fprintf(stderr, "warning: input \"%s\" of type %s not supported; ignored\n", v->name.c_str(), v->type.c_str());
      continue;
    }
    cols.push_back({c, v});
  }
  std::vector<double> tcsv;
  std::vector<std::vector<double>> table(cols.size());
  size_t lineNo = 1;
  while (std::getline(fin, line)) {
    ++lineNo;
    if (line.find_first_not_of(" \r\n") == std::string::npos) continue;
    splitCsv(line, f);
    if (f.size() < 1) continue;
    char* endp = nullptr;
    double t = std::strtod(f[0].c_str(), &endp);
    if (endp == f[0].c_str()) { std::fprintf(stderr, "error: %s:%zu: bad time\n", in.c_str(), lineNo); return 1; }
    tcsv.push_back(t);
    for (size_t k = 0; k < cols.size(); ++k) {
      if (cols[k].csv >= f.size()) { std::fprintf(stderr, "error: %s:%zu: short row\n", in.c_str(), lineNo); return 1; }
      const std::string& s = f[cols[k].csv];
      double x = (s == "true" || s == "True") ? 1.0 : (s == "false" || s == "False") ? 0.0 : std::strtod(s.c_str(), nullptr);
      table[k].push_back(x);
    }
  }
  if (tcsv.empty()) { std::fprintf(stderr, "error: %s has no data rows\n", in.c_str()); return 1; }
  const double t0 = tcsv.front();
  if (std::isnan(stop)) stop = tcsv.back();

  // Input value at time `time` exactly as FMPy's Input.interpolate (continuous Real inputs:
  // linear; Integer/Boolean: previous sample).
  auto inputAt = [&](size_t k, double time) -> double {
    const auto& v = table[k];
    if (tcsv.size() < 2) return v[0];
    size_t i0 = static_cast<size_t>(std::lower_bound(tcsv.begin(), tcsv.end(), time) - tcsv.begin());
    if (i0 == 0) return v[0];
    if (i0 == tcsv.size()) return v.back();
    if (cols[k].var->type != "Real") {
      size_t i = i0 - 1;
      while (i + 1 < tcsv.size() && (tcsv[i + 1] < time || std::fabs(time - tcsv[i + 1]) <= 1e-9 * std::max(std::fabs(time), 1.0) )) ++i;
      return v[i];
    }
    size_t a = i0 - 1, b = i0;
    double w0 = (tcsv[b] - time) / (tcsv[b] - tcsv[a]);
    double w1 = 1 - w0;
    return w0 * v[a] + w1 * v[b];
  };

  // Communication points t_k = t0 + k*h (FMPy's rule), the last one clipped to the stop time.
  auto isclose = [](double a, double b) { return std::fabs(a - b) <= 1e-9 * std::max(std::fabs(a), std::fabs(b)); };
  std::vector<double> tp{t0};
  for (size_t k = 1; !(tp.back() > stop || isclose(tp.back(), stop)); ++k) {
    double t = t0 + static_cast<double>(k) * step;
    tp.push_back(t > stop && !isclose(t, stop) ? stop : t);
  }
  const size_t nSteps = tp.size() - 1;

  // Precompute every input value (no work but the FMU calls inside the timed loop).
  std::vector<fmi2ValueReference> rvr, ivr, evr, bvr;
  std::vector<size_t> rcol, icol, ecol, bcol;
  for (size_t k = 0; k < cols.size(); ++k) {
    if (cols[k].var->type == "Real") { rvr.push_back(cols[k].var->vr); rcol.push_back(k); }
    else if (cols[k].var->type == "Integer") { ivr.push_back(cols[k].var->vr); icol.push_back(k); }
    else if (cols[k].var->type == "Enum") { evr.push_back(cols[k].var->vr); ecol.push_back(k); }
    else { bvr.push_back(cols[k].var->vr); bcol.push_back(k); }
  }
  std::vector<double> rin((nSteps + 1) * rvr.size());
  std::vector<fmi2Integer> iin((nSteps + 1) * ivr.size());
  std::vector<fmi3Int64> ein((nSteps + 1) * evr.size());
  std::vector<fmi2Boolean> bin((nSteps + 1) * bvr.size());
  std::unique_ptr<fmi3Boolean[]> bin3(new fmi3Boolean[(nSteps + 1) * bvr.size() + 1]);  // not vector<bool>
  for (size_t s = 0; s <= nSteps; ++s) {
    for (size_t j = 0; j < rvr.size(); ++j) rin[s * rvr.size() + j] = inputAt(rcol[j], tp[s]);
    for (size_t j = 0; j < ivr.size(); ++j) iin[s * ivr.size() + j] = static_cast<fmi2Integer>(inputAt(icol[j], tp[s]));
    for (size_t j = 0; j < evr.size(); ++j) ein[s * evr.size() + j] = static_cast<fmi3Int64>(inputAt(ecol[j], tp[s]));
    for (size_t j = 0; j < bvr.size(); ++j) {
      bin[s * bvr.size() + j] = inputAt(bcol[j], tp[s]) != 0.0;
      bin3[s * bvr.size() + j] = bin[s * bvr.size() + j] != 0;
    }
  }
  std::vector<const Var*> outs;
  std::vector<fmi2ValueReference> orv, oiv, oev, obv;
  for (const auto& v : md.vars) {
    if (v.causality != "output") continue;
    if (v.type == "Real") orv.push_back(v.vr);
    else if (v.type == "Integer") oiv.push_back(v.vr);
    else if (v.type == "Enum") oev.push_back(v.vr);
    else if (v.type == "Boolean") obv.push_back(v.vr);
    else continue;
    outs.push_back(&v);
  }
  std::vector<double> rout((nSteps + 1) * orv.size());
  std::vector<fmi2Integer> iout((nSteps + 1) * oiv.size());
  std::vector<fmi3Int64> eout((nSteps + 1) * oev.size());
  std::vector<fmi2Boolean> bout((nSteps + 1) * obv.size());
  std::unique_ptr<fmi3Boolean[]> bout3(new fmi3Boolean[obv.size() + 1]);

  // ---- load the FMU ----
  const std::string so = fmuimport::binaryPath(dir, md.id, md.fmi3);
  std::string loadErr;
  void* lib = fmuimport::openLibrary(so, loadErr);
  if (!lib) { std::fprintf(stderr, "error: loading %s: %s\n", so.c_str(), loadErr.c_str()); return 1; }
  fmuimport::Fmi2Api api;
  fmuimport::Fmi3Api api3;
  if (!(md.fmi3 ? api3.load(lib, loadErr) : api.load(lib, loadErr))) {
    std::fprintf(stderr, "error: %s\n", loadErr.c_str());
    return 1;
  }
  const char* v = md.fmi3 ? "fmi3" : "fmi2";  // for messages
  void* c = nullptr;
  fmi2CallbackFunctions cb{};
  cb.logger = logger;
  cb.allocateMemory = calloc;
  cb.freeMemory = free;
  if (md.fmi3) {
    std::string res = dir + "/resources/";
    c = api3.instantiate("rt", md.guid.c_str(), res.c_str(), false, logOn, false, false, nullptr, 0, nullptr,
                         logMessage3, nullptr);
  } else {
    std::string res = "file://" + dir + "/resources";
    c = api.instantiate("rt", fmi2CoSimulation, md.guid.c_str(), res.c_str(), &cb, fmi2False,
                        logOn ? fmi2True : fmi2False);
  }
  if (!c) { std::fprintf(stderr, "error: %sInstantiate failed\n", v); return 1; }
  // The calls of the loop, for either version (statuses as ints: FMI 2.0's and 3.0's agree).
  auto freeInstance = [&] { md.fmi3 ? api3.freeInstance(c) : api.freeInstance(c); };
  auto terminate = [&] { md.fmi3 ? (void)api3.terminate(c) : (void)api.terminate(c); };
  auto fail = [&](const std::string& what) {
    std::fprintf(stderr, "error: %s failed\n", what.c_str());
    freeInstance();
    return 1;
  };
  if (!md.fmi3 && api.setupExperiment(c, fmi2False, 0.0, t0, fmi2False, 0.0) > fmi2Warning)
    return fail("fmi2SetupExperiment");
  for (const auto& kv : params) {
    const Var* var = nullptr;
    for (const auto& x : md.vars)
      if (x.name == kv.first) var = &x;
    if (!var) { std::fprintf(stderr, "error: no variable \"%s\"\n", kv.first.c_str()); freeInstance(); return 2; }
    int st;
    if (var->type == "Real") {
      double x = std::strtod(kv.second.c_str(), nullptr);
      st = md.fmi3 ? int(api3.setFloat64(c, &var->vr, 1, &x, 1)) : int(api.setReal(c, &var->vr, 1, &x));
    } else if (var->type == "Integer") {
      fmi2Integer x = std::atoi(kv.second.c_str());
      st = md.fmi3 ? int(api3.setInt32(c, &var->vr, 1, &x, 1)) : int(api.setInteger(c, &var->vr, 1, &x));
    } else if (var->type == "Enum") {
      fmi3Int64 x = std::atoll(kv.second.c_str());
      st = api3.setInt64(c, &var->vr, 1, &x, 1);
    } else if (var->type == "Boolean") {
      const bool x = kv.second == "true" || kv.second == "1";
      fmi2Boolean x2 = x;
      fmi3Boolean x3 = x;
      st = md.fmi3 ? int(api3.setBoolean(c, &var->vr, 1, &x3, 1)) : int(api.setBoolean(c, &var->vr, 1, &x2));
    } else {
      std::fprintf(stderr, "error: cannot set %s\n", var->name.c_str());
      freeInstance();
      return 2;
    }
    if (st > fmi2Warning) return fail("setting " + kv.first);
  }
  if ((md.fmi3 ? int(api3.enterInitializationMode(c, false, 0.0, t0, false, 0.0)) : int(api.enterInitializationMode(c))) >
      fmi2Warning)
    return fail(std::string(v) + "EnterInitializationMode");
  auto setInputs = [&](size_t s) -> int {
    int st = 0;
    if (md.fmi3) {
      if (!rvr.empty()) st = std::max<int>(st, api3.setFloat64(c, rvr.data(), rvr.size(), &rin[s * rvr.size()], rvr.size()));
      if (!ivr.empty()) st = std::max<int>(st, api3.setInt32(c, ivr.data(), ivr.size(), &iin[s * ivr.size()], ivr.size()));
      if (!evr.empty()) st = std::max<int>(st, api3.setInt64(c, evr.data(), evr.size(), &ein[s * evr.size()], evr.size()));
      if (!bvr.empty()) st = std::max<int>(st, api3.setBoolean(c, bvr.data(), bvr.size(), &bin3[s * bvr.size()], bvr.size()));
      return st;
    }
    if (!rvr.empty()) st = std::max<int>(st, api.setReal(c, rvr.data(), rvr.size(), &rin[s * rvr.size()]));
    if (!ivr.empty()) st = std::max<int>(st, api.setInteger(c, ivr.data(), ivr.size(), &iin[s * ivr.size()]));
    if (!bvr.empty()) st = std::max<int>(st, api.setBoolean(c, bvr.data(), bvr.size(), &bin[s * bvr.size()]));
    return st;
  };
  auto getOutputs = [&](size_t s) -> int {
    int st = 0;
    if (md.fmi3) {
      if (!orv.empty()) st = std::max<int>(st, api3.getFloat64(c, orv.data(), orv.size(), &rout[s * orv.size()], orv.size()));
      if (!oiv.empty()) st = std::max<int>(st, api3.getInt32(c, oiv.data(), oiv.size(), &iout[s * oiv.size()], oiv.size()));
      if (!oev.empty()) st = std::max<int>(st, api3.getInt64(c, oev.data(), oev.size(), &eout[s * oev.size()], oev.size()));
      if (!obv.empty()) {
        st = std::max<int>(st, api3.getBoolean(c, obv.data(), obv.size(), bout3.get(), obv.size()));
        for (size_t j = 0; j < obv.size(); ++j) bout[s * obv.size() + j] = bout3[j];
      }
      return st;
    }
    if (!orv.empty()) st = std::max<int>(st, api.getReal(c, orv.data(), orv.size(), &rout[s * orv.size()]));
    if (!oiv.empty()) st = std::max<int>(st, api.getInteger(c, oiv.data(), oiv.size(), &iout[s * oiv.size()]));
    if (!obv.empty()) st = std::max<int>(st, api.getBoolean(c, obv.data(), obv.size(), &bout[s * obv.size()]));
    return st;
  };
  auto doStep = [&](double t, double h) -> int {
    if (!md.fmi3) return api.doStep(c, t, h, fmi2True);
    fmi3Boolean eventHandlingNeeded = false, terminateSimulation = false, earlyReturn = false;
    fmi3Float64 lastSuccessfulTime = 0.0;
    return api3.doStep(c, t, h, true, &eventHandlingNeeded, &terminateSimulation, &earlyReturn, &lastSuccessfulTime);
  };
  if (setInputs(0) > fmi2Warning) return fail("setting the inputs");
  if ((md.fmi3 ? int(api3.exitInitializationMode(c)) : int(api.exitInitializationMode(c))) > fmi2Warning)
    return fail(std::string(v) + "ExitInitializationMode");
  if (getOutputs(0) > fmi2Warning) return fail("getting the outputs");

  // ---- real-time loop ----
#ifndef _WIN32
  if (mlock && mlockall(MCL_CURRENT | MCL_FUTURE) != 0) std::fprintf(stderr, "warning: mlockall failed\n");
  if (prio > 0) {
    sched_param sp{};
    sp.sched_priority = prio;
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
      std::fprintf(stderr, "warning: SCHED_FIFO priority %d not granted (needs CAP_SYS_NICE)\n", prio);
  }
#else
  if (mlock || prio > 0) std::fprintf(stderr, "warning: --mlock and --rt-priority are ignored on Windows\n");
#endif
  std::vector<int64_t> exec(nSteps), late(fast ? 0 : nSteps);
  std::vector<char> missed(nSteps, 0);
  const int64_t periodNs = static_cast<int64_t>(std::llround(step * 1e9));
  size_t misses = 0, done = 0;
  int rc = 0;
  const int64_t start = nowNs() + (fast ? 0 : periodNs);  // first deadline one period ahead
  for (size_t s = 0; s < nSteps; ++s) {
    const int64_t deadline = start + static_cast<int64_t>(s) * periodNs;
    if (!fast) {
      sleepUntil(deadline);
      late[s] = nowNs() - deadline;
    }
    int st = s == 0 ? 0 : setInputs(s);
    const int64_t a = nowNs();
    const int ds = doStep(tp[s], tp[s + 1] - tp[s]);
    const int64_t b = nowNs();
    exec[s] = b - a;
    st = std::max(st, getOutputs(s + 1));
    if (!fast && nowNs() > deadline + periodNs) {  // the period's work overran the next deadline
      missed[s] = 1;
      ++misses;
    }
    done = s + 1;
    if (ds > fmi2Warning || st > fmi2Warning) {
      std::fprintf(stderr, "error: %sDoStep at t=%.17g returned status %d\n", v, tp[s], ds);
      rc = 1;
      break;
    }
  }
  terminate();
  freeInstance();

  // ---- results ----
  if (!out.empty()) {
    FILE* fo = std::fopen(out.c_str(), "w");
    if (!fo) { std::fprintf(stderr, "error: cannot write %s\n", out.c_str()); return 1; }
    std::fprintf(fo, "time");
    for (const Var* o : outs) std::fprintf(fo, ",%s", o->name.c_str());
    std::fprintf(fo, "\n");
    for (size_t s = 0; s <= done; ++s) {
      std::fprintf(fo, "%.17g", tp[s]);
      size_t ri = 0, ii = 0, ei = 0, bi = 0;
      for (const Var* o : outs) {
        if (o->type == "Real") std::fprintf(fo, ",%.17g", rout[s * orv.size() + ri++]);
        else if (o->type == "Integer") std::fprintf(fo, ",%d", iout[s * oiv.size() + ii++]);
        else if (o->type == "Enum") std::fprintf(fo, ",%lld", static_cast<long long>(eout[s * oev.size() + ei++]));
        else std::fprintf(fo, ",%d", bout[s * obv.size() + bi++] ? 1 : 0);
      }
      std::fprintf(fo, "\n");
    }
    if (std::fclose(fo) != 0) { std::fprintf(stderr, "error: cannot write %s\n", out.c_str()); return 1; }
  }
  if (!timings.empty()) {
    FILE* ft = std::fopen(timings.c_str(), "w");
    if (!ft) { std::fprintf(stderr, "error: cannot write %s\n", timings.c_str()); return 1; }
    std::fprintf(ft, "step,time,exec_ns,lateness_ns,miss\n");
    for (size_t s = 0; s < done; ++s)
      std::fprintf(ft, "%zu,%.17g,%lld,%lld,%d\n", s, tp[s], static_cast<long long>(exec[s]),
                   fast ? 0LL : static_cast<long long>(late[s]), missed[s]);
    if (std::fclose(ft) != 0) { std::fprintf(stderr, "error: cannot write %s\n", timings.c_str()); return 1; }
  }
  exec.resize(done);
  if (!fast) late.resize(done);
  double mean = 0;
  for (auto e : exec) mean += static_cast<double>(e);
  mean = exec.empty() ? 0 : mean / static_cast<double>(exec.size()) / 1000.0;
  std::printf("model: %s\nmode: %s\nperiod_s: %.9g\nsteps: %zu\n", md.id.c_str(), fast ? "fast" : "realtime", step, done);
  std::printf("doStep_us: p50=%.3f p99=%.3f p99.9=%.3f max=%.3f mean=%.3f\n", pct(exec, 50), pct(exec, 99),
              pct(exec, 99.9), pct(exec, 100), mean);
  if (!fast) {
    std::printf("lateness_us: p50=%.3f p99=%.3f p99.9=%.3f max=%.3f\n", pct(late, 50), pct(late, 99), pct(late, 99.9),
                pct(late, 100));
    std::printf("deadline_misses: %zu\n", misses);
  } else {
    std::printf("lateness_us: n/a (fast mode)\ndeadline_misses: n/a (fast mode)\n");
  }
  return rc;
}
