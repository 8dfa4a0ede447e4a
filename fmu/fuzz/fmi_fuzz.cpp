// Coverage-guided FMI fuzzer (libFuzzer), one executable per FMU (<Model>_fuzz, built with
// -DANKLEHIP_FUZZ=ON, see docs/reliability.md), linked with the same glue and model objects as the
// shipped binaries and with both C APIs (FMI 2.0 and the FMI 3.0 twin's). The first byte of an
// input chooses how the rest is decoded:
//
//   byte % 4 == 0: a *shallow* program of FMI 2.0 calls on up to two instances (ShallowProgram):
//     instantiation with odd arguments, set-up and mode changes in any order, get/set of every type
//     with valid and invalid value references, arrays of up to thousands of entries, special values
//     (NaN, +-Inf, +-1e308, denormals, -0), steps of any size and at any time (those the FMU takes
//     within two of its largest steps' work per input, ShallowProgram::affordable), FMU states got, set,
//     freed, serialized and deserialized (bit-flipped, truncated, foreign, another instance's),
//     reset, terminate, cancel, status queries with any kind, debug logging with unknown categories;
//   otherwise a *deep*, structure-aware program (DeepProgram) through FMI 2.0 (% 4 == 1, 3) or FMI
//     3.0 (% 4 == 2; for a model with a Scheduled Execution clock, every other such program instantiates
//     it for Scheduled Execution and its steps are clock activations, fmi3ActivateModelPartition):
//     a realistic initialization (parameters mostly at or inside their declared ranges, sometimes
//     outside; in a third of the programs a mode plausible inputs never reach, the 3D controller's
//     stepping with a step at a set time: DeepProgram::stepping_mode), then mostly steps with
//     plausible inputs (for the unit of each input: angles of a few degrees, a ZMP on the foot, the
//     robot's weight, pushes of a few newtons; rarely NaN or huge), interleaved with FMU states
//     got, set, serialized and deserialized into a second instance, which must then continue bit
//     for bit like the first;
//     forged-but-re-signed state blobs (a value replaced, the checksum recomputed), which must be
//     refused or behave (steps OK, Warning or Discard, every output finite); parameter changes
//     inside and outside their ranges; reset and re-initialization. With bit 3 of the byte set, a
//     step's inputs cost one byte (mostly held, sometimes one or all new: DeepProgram::compact).
//
// Every input ends by freeing its instances (and with them the states still held), so
// LeakSanitizer sees every leak. A crash, a sanitizer report, a leak, a slow input (-timeout), a
// restored state that does not continue bit for bit or an accepted forged state that misbehaves is
// a finding. At exit the harness prints the number of deep programs and their successful steps.
//
// Seeds: fmu/fuzz/make_seeds.py writes them in this format.
#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "fmi2Functions.h"
#include "fmi3Functions.h"
#include "fmuglue/glue.hpp"
#include "instance.hpp"  // the glue's instance: a step's work against the model's largest step

namespace {

class Bytes {
 public:
  Bytes(const std::uint8_t* p, std::size_t n) : p_(p), n_(n) {}
  bool empty() const { return i_ >= n_; }
  std::uint8_t u8() { return i_ < n_ ? p_[i_++] : 0; }
  std::uint16_t u16() { return static_cast<std::uint16_t>(u8() | (u8() << 8)); }
  std::uint32_t u32() { return static_cast<std::uint32_t>(u16()) | (static_cast<std::uint32_t>(u16()) << 16); }
  double raw_f64() {
    std::uint64_t b = static_cast<std::uint64_t>(u32()) | (static_cast<std::uint64_t>(u32()) << 32);
    double d;
    std::memcpy(&d, &b, sizeof d);
    return d;
  }
  // A value: mostly one of the special values below, sometimes raw bits.
  double real() {
    static const double kSpecial[] = {0.0, -0.0, 1e-3, 1.0, -1.0, 0.5, 0.05, -0.05, 70.0, 9.81, 1e-6, 2e-3, 0.999e-3,
                                      std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(),
                                      -std::numeric_limits<double>::infinity(), 1e308, -1e308, 4.9e-324, 2.2e-310,
                                      1e-300, 1e5, 1e6, 1.85e16, 1e303, std::numeric_limits<double>::max(),
                                      std::numeric_limits<double>::lowest(), 1000.0, 1001.0, 3600.0, 50.0, 1e10};
    const std::uint8_t b = u8();
    if (b < 224) return kSpecial[b % (sizeof kSpecial / sizeof kSpecial[0])];
    return raw_f64();
  }
  int integer() {
    static const int kSpecial[] = {0, 1, -1, 2, 3, 7, 100, -100, 2147483647, -2147483647 - 1};
    const std::uint8_t b = u8();
    return b < 224 ? kSpecial[b % (sizeof kSpecial / sizeof kSpecial[0])] : static_cast<int>(u32());
  }
  std::vector<std::uint8_t> rest_chunk(std::size_t max) {
    std::size_t k = std::min<std::size_t>(max, n_ - std::min(i_, n_));
    std::vector<std::uint8_t> v(p_ + i_, p_ + i_ + k);
    i_ += k;
    return v;
  }

 private:
  const std::uint8_t* p_;
  std::size_t n_, i_ = 0;
};

std::string g_last_error;  // the last message logged with fmi2Error / fmi3Error (the deep oracle reads it)

void logger(fmi2ComponentEnvironment, fmi2String name, fmi2Status status, fmi2String category, fmi2String message,
            ...) {
  // An importer's logger treats the message as a format: do the same (the glue escapes '%').
  char buf[2048];
  va_list ap;
  va_start(ap, message);
  std::vsnprintf(buf, sizeof buf, message ? message : "", ap);
  va_end(ap);
  if (status == fmi2Error) g_last_error = buf;
  (void)name;
  (void)category;
}
void* alloc(size_t n, size_t s) { return std::calloc(n, s); }
void release(void* p) { std::free(p); }
const fmi2CallbackFunctions kCallbacks = {logger, alloc, release, nullptr, nullptr};

struct Slot {
  fmi2Component c = nullptr;
  std::vector<fmi2FMUstate> states;  // may hold freed or foreign pointers: the glue must cope
};

struct ShallowProgram {
  Slot slot[2];
  std::vector<std::vector<std::uint8_t>> blobs;  // serialized states seen so far
  const fmuglue::ModelInfo& info = fmuglue::modelInfo();
  const std::string& guid = fmuglue::thisModelGuid();

  fmi2ValueReference vr(Bytes& in) {
    const std::uint8_t b = in.u8();
    if (b < 230 && !info.variables.empty()) return info.variables[b % info.variables.size()].vr;
    return b < 250 ? in.u32() : static_cast<fmi2ValueReference>(b);
  }
  std::size_t count(Bytes& in) {
    const std::uint8_t b = in.u8();
    if (b < 200) return b % 8;
    if (b < 250) return b % 64;
    return 1 + in.u16() % 4096;  // up to thousands of entries
  }
  double now(fmi2Component c) {
    fmi2Real t = 0.0;
    return fmi2GetRealStatus(c, fmi2LastSuccessfulTime, &t) == fmi2OK ? t : 0.0;
  }

  // The steps of one program do at most kStepWork of the FMU's largest steps' work
  // (Model::max_step_size, each about 0.1 s of native computation, docs/fmu.md): an input's time
  // stays far below libFuzzer's -timeout under the sanitizers, whatever its steps (four 1000 s steps
  // of the 3D controller took 27 s). A step the FMU must refuse (h beyond its largest, or not > 0)
  // is always made; one the budget cannot pay for is not.
  static constexpr double kStepWork = 2.0;
  double work = 0.0;
  bool affordable(fmi2Component c, double h) {
    const fmuglue::Instance* inst = static_cast<const fmuglue::Instance*>(c);
    const double hmax = inst->model ? inst->model->max_step_size(inst->ctx) : 0.0;
    if (!(h > 0.0) || !(h <= hmax)) return true;
    if (work + h / hmax > kStepWork) return false;
    work += h / hmax;
    return true;
  }

  // Passes any int as fmi2Type, as a C caller can: the glue must read it without loading an
  // invalid enum (UBSan checks the glue), so only this harness function is exempt.
  __attribute__((no_sanitize("enum"))) void instantiate(Slot& s, Bytes& in) {
    if (s.c) fmi2FreeInstance(s.c);
    s = Slot();
    const std::uint8_t v = in.u8();
    const char* name = v % 11 == 0 ? nullptr : v % 11 == 1 ? "" : "fuzz";
    const std::string wrong = guid.substr(0, guid.size() / 2);
    const char* g = v % 13 == 2 ? "{00000000-0000-0000-0000-000000000000}"
                    : v % 13 == 3 ? nullptr
                    : v % 13 == 4 ? wrong.c_str()
                                  : guid.c_str();
    int type_raw = v % 17 == 5 ? 0 : v % 17 == 6 ? 77 : v % 17 == 7 ? -1 : fmi2CoSimulation;
    fmi2Type type;
    std::memcpy(&type, &type_raw, sizeof type);  // any int the caller may pass
    const char* res = v % 7 == 1 ? nullptr : v % 7 == 2 ? "" : "file:///nonexistent/resources";
    const fmi2CallbackFunctions* cb = v % 19 == 9 ? nullptr : &kCallbacks;
    s.c = fmi2Instantiate(name, type, g, res, cb, fmi2False, (v & 0x80) ? fmi2True : fmi2False);
  }

  void set(fmi2Component c, Bytes& in, int type) {
    const std::size_t n = count(in);
    std::vector<fmi2ValueReference> vrs(n);
    for (auto& r : vrs) r = vr(in);
    const fmi2ValueReference* pv = (in.u8() % 31 == 0) ? nullptr : vrs.data();
    switch (type) {
      case 0: {
        std::vector<fmi2Real> x(n);
        for (auto& v : x) v = in.real();
        fmi2SetReal(c, pv, n, n ? x.data() : nullptr);
        break;
      }
      case 1: {
        std::vector<fmi2Integer> x(n);
        for (auto& v : x) v = in.integer();
        fmi2SetInteger(c, pv, n, n ? x.data() : nullptr);
        break;
      }
      case 2: {
        std::vector<fmi2Boolean> x(n);
        for (auto& v : x) v = in.integer();
        fmi2SetBoolean(c, pv, n, n ? x.data() : nullptr);
        break;
      }
      default: {
        std::vector<std::string> text(n);
        std::vector<fmi2String> x(n);
        for (std::size_t k = 0; k < n; ++k) {
          text[k] = std::string(in.u8() % 40, static_cast<char>('a' + k % 26));
          x[k] = in.u8() % 29 == 0 ? nullptr : text[k].c_str();
        }
        fmi2SetString(c, pv, n, n ? x.data() : nullptr);
      }
    }
  }

  void get(fmi2Component c, Bytes& in) {
    const int type = in.u8() % 4;
    const std::size_t n = count(in);
    std::vector<fmi2ValueReference> vrs(n);
    for (auto& r : vrs) r = vr(in);
    std::vector<fmi2Real> r(n);
    std::vector<fmi2Integer> i(n);
    std::vector<fmi2String> s(n);
    if (type == 0) fmi2GetReal(c, vrs.data(), n, r.data());
    if (type == 1) fmi2GetInteger(c, vrs.data(), n, i.data());
    if (type == 2) fmi2GetBoolean(c, vrs.data(), n, i.data());
    if (type == 3 && fmi2GetString(c, vrs.data(), n, s.data()) == fmi2OK)
      for (fmi2String x : s) (void)std::strlen(x);  // the pointers must be valid
  }

  fmi2FMUstate pick_state(Bytes& in) {
    Slot& s = slot[in.u8() & 1];  // this instance's or the other's
    if (s.states.empty()) return nullptr;
    return s.states[in.u8() % s.states.size()];
  }

  void serialize(fmi2Component c, Bytes& in) {
    fmi2FMUstate st = pick_state(in);
    size_t size = 0;
    if (fmi2SerializedFMUstateSize(c, st, &size) != fmi2OK) return;
    if (size > (1u << 24)) std::abort();  // an FMU state is a few kB: this would be a defect
    const std::uint8_t v = in.u8();
    std::vector<fmi2Byte> buf(size + 16);
    const size_t given = v % 9 == 0 && size ? size - 1 : size;  // too small a buffer must be refused
    if (fmi2SerializeFMUstate(c, st, buf.data(), given) == fmi2OK) {
      buf.resize(size);
      blobs.emplace_back(buf.begin(), buf.end());
      if (blobs.size() > 8) blobs.erase(blobs.begin());
    }
  }

  void deserialize(Slot& s, Bytes& in) {
    std::vector<std::uint8_t> b;
    const std::uint8_t v = in.u8();
    if (!blobs.empty()) b = blobs[in.u8() % blobs.size()];
    switch (v % 6) {
      case 0: break;  // as serialized
      case 1:         // bit flips
        for (int k = in.u8() % 4; k >= 0 && !b.empty(); --k) b[in.u16() % b.size()] ^= static_cast<std::uint8_t>(1u << (in.u8() % 8));
        break;
      case 2: b.resize(b.empty() ? 0 : in.u16() % b.size()); break;  // truncated
      case 3: {  // padded with junk
        auto junk = in.rest_chunk(in.u8());
        b.insert(b.end(), junk.begin(), junk.end());
        break;
      }
      case 4: b = in.rest_chunk(in.u16() % 2048); break;  // foreign bytes
      default:  // an 8-byte value overwritten (the checksum then fails, unless the fuzzer fixes it)
        if (b.size() > 16) {
          const double x = in.real();
          std::memcpy(&b[in.u16() % (b.size() - 8)], &x, 8);
        }
    }
    fmi2FMUstate st = (v & 0x40) ? pick_state(in) : nullptr;
    if (fmi2DeSerializeFMUstate(s.c, reinterpret_cast<const fmi2Byte*>(b.data()), b.size(), &st) == fmi2OK &&
        (v & 0x40) == 0)
      s.states.push_back(st);
  }

  // Status queries with any int as fmi2StatusKind (exempt from the enum check, as instantiate).
  __attribute__((no_sanitize("enum"))) void status(fmi2Component c, Bytes& in) {
    const int kind_raw = (in.u8() % 5 == 0) ? static_cast<int>(in.u32()) : in.u8() % 4;
    fmi2StatusKind kind;
    std::memcpy(&kind, &kind_raw, sizeof kind);
    fmi2Status st;
    fmi2Real r;
    fmi2Integer i;
    fmi2Boolean b;
    fmi2String str;
    const bool null_out = in.u8() % 7 == 0;
    switch (in.u8() % 5) {
      case 0: fmi2GetStatus(c, kind, null_out ? nullptr : &st); break;
      case 1: fmi2GetRealStatus(c, kind, null_out ? nullptr : &r); break;
      case 2: fmi2GetIntegerStatus(c, kind, null_out ? nullptr : &i); break;
      case 3: fmi2GetBooleanStatus(c, kind, null_out ? nullptr : &b); break;
      default: fmi2GetStringStatus(c, kind, null_out ? nullptr : &str); break;
    }
  }

  void step_many(fmi2Component c, Bytes& in) {
    const int k = in.u8() % 64;
    double t = now(c);
    for (int i = 0; i < k && affordable(c, 1e-3); ++i) {
      if (fmi2DoStep(c, t, 1e-3, fmi2False) > fmi2Warning) break;
      t += 1e-3;
    }
  }

  void run(Bytes& in) {
    int budget = 256;  // operations per input
    while (!in.empty() && budget-- > 0) {
      const std::uint8_t op = in.u8();
      Slot& s = slot[(op >> 7) & 1];
      const int code = op & 0x1f;
      if (code == 0) { instantiate(s, in); continue; }
      if (s.c == nullptr) continue;  // calls on a freed or failed instance are the importer's bug
      fmi2Component c = s.c;
      switch (code) {
        case 1: fmi2FreeInstance(c); s = Slot(); break;
        case 2: {
          const std::uint8_t f = in.u8();
          const double tol = in.real(), start = in.real(), stop = in.real();
          fmi2SetupExperiment(c, f & 1, tol, start, (f >> 1) & 1, stop);
          break;
        }
        case 3: fmi2EnterInitializationMode(c); break;
        case 4: fmi2ExitInitializationMode(c); break;
        case 5: fmi2Terminate(c); break;
        case 6: fmi2Reset(c); break;
        case 7: case 8: case 9: case 10: set(c, in, code - 7); break;
        case 11: get(c, in); break;
        case 12: {
          const std::uint8_t f = in.u8();
          const double t = (f & 1) ? in.real() : now(c);
          const double h = in.real();
          if (affordable(c, h)) fmi2DoStep(c, t, h, (f >> 1) & 1);
          break;
        }
        case 13: step_many(c, in); break;
        case 14: {
          fmi2FMUstate st = (in.u8() & 1) ? pick_state(in) : nullptr;
          const bool fresh = st == nullptr;
          if (fmi2GetFMUstate(c, &st) == fmi2OK && fresh) s.states.push_back(st);
          break;
        }
        case 15: fmi2SetFMUstate(c, pick_state(in)); break;
        case 16: {
          fmi2FMUstate st = pick_state(in);
          fmi2FreeFMUstate(c, &st);  // stale copies stay in the list on purpose
          break;
        }
        case 17: serialize(c, in); break;
        case 18: deserialize(s, in); break;
        case 19: status(c, in); break;
        case 20: {
          static const char* const kNames[] = {"logEvents", "logStatusWarning", "logStatusDiscard", "logStatusError",
                                               "logStatusFatal", "logCalls", "logSolver", "noSuchCategory", "", nullptr};
          const std::size_t n = in.u8() % 6;
          std::vector<fmi2String> cats(n);
          for (auto& x : cats) x = kNames[in.u8() % 10];
          fmi2SetDebugLogging(c, in.u8() & 1, n, (in.u8() % 9 == 0) ? nullptr : cats.data());
          break;
        }
        case 21: fmi2CancelStep(c); break;
        case 22: {
          fmi2ValueReference a = vr(in), b = vr(in);
          fmi2Real dv = 1.0, out = 0.0;
          fmi2Integer order = 1;
          fmi2GetDirectionalDerivative(c, &a, 1, &b, 1, &dv, &out);
          fmi2SetRealInputDerivatives(c, &a, 1, &order, &dv);
          fmi2GetRealOutputDerivatives(c, &a, 1, &order, &out);
          break;
        }
        default:  // the common path, so the fuzzer reaches deep simulation states cheaply
          fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
          fmi2EnterInitializationMode(c);
          fmi2ExitInitializationMode(c);
          step_many(c, in);
      }
    }
    for (Slot& x : slot)
      if (x.c) fmi2FreeInstance(x.c);  // frees the states still held
  }
};

}  // namespace

namespace {

// ---- The deep, structure-aware programs ------------------------------------------------------

// Counters printed at exit: what the deep programs reached.
struct DeepStats {
  unsigned long long programs = 0, steps_ok = 0, steps = 0, restores = 0, forged = 0, forged_accepted = 0;
  ~DeepStats() {
    if (programs)
      std::fprintf(stderr, "deep programs: %llu, successful steps %llu (%.1f per program) of %llu, bit-exact "
                   "restores %llu, forged states %llu (%llu accepted)\n",
                   programs, steps_ok, double(steps_ok) / double(programs), steps, restores, forged, forged_accepted);
  }
};
DeepStats g_deep;

// A finding that is not a crash: report it and abort (libFuzzer saves the input).
[[noreturn]] void finding(const char* what, const char* detail) {
  std::fprintf(stderr, "FINDING: %s: %s\n", what, detail);
  std::abort();
}

void logger3(fmi3InstanceEnvironment, fmi3Status status, fmi3String, fmi3String message) {
  if (status == fmi3Error) g_last_error = message ? message : "";
}

// One instance through either C API: the calls a deep program makes, with FMI 2.0's statuses.
struct Api {
  int version = 2;
  void* c = nullptr;
  // FMI 3.0 Scheduled Execution (the model's ModelInfo::clock): a step is one activation of the clock
  bool scheduled = false;
  fmi3ValueReference clock = 0;

  bool instantiate(const char* name, const std::string& guid, bool logging) {
    if (scheduled)
      c = fmi3InstantiateScheduledExecution(name, guid.c_str(), "/nonexistent/resources/", fmi3False, logging, nullptr,
                                            logger3, nullptr, nullptr, nullptr);
    else if (version == 2)
      c = fmi2Instantiate(name, fmi2CoSimulation, guid.c_str(), "file:///nonexistent/resources", &kCallbacks, fmi2False,
                          logging ? fmi2True : fmi2False);
    else
      c = fmi3InstantiateCoSimulation(name, guid.c_str(), "/nonexistent/resources/", fmi3False, logging, fmi3False,
                                      fmi3False, nullptr, 0, nullptr, logger3, nullptr);
    return c != nullptr;
  }
  void free() {
    if (!c) return;
    if (version == 2) fmi2FreeInstance(c);
    else fmi3FreeInstance(c);
    c = nullptr;
  }
  int enter(double start, bool stop_defined, double stop) {
    if (version == 2) {
      int st = fmi2SetupExperiment(c, fmi2False, 0.0, start, stop_defined, stop);
      return st > fmi2Warning ? st : fmi2EnterInitializationMode(c);
    }
    return fmi3EnterInitializationMode(c, fmi3False, 0.0, start, stop_defined, stop);
  }
  int exit() { return version == 2 ? fmi2ExitInitializationMode(c) : fmi3ExitInitializationMode(c); }
  int step(double t, double h) {
    if (scheduled) return fmi3ActivateModelPartition(c, clock, t);  // h is the clock's interval (DeepProgram)
    if (version == 2) return fmi2DoStep(c, t, h, fmi2False);
    fmi3Boolean event = fmi3False, terminate = fmi3False, early = fmi3False;
    fmi3Float64 last = 0.0;
    return fmi3DoStep(c, t, h, fmi3False, &event, &terminate, &early, &last);
  }
  int reset() { return version == 2 ? fmi2Reset(c) : fmi3Reset(c); }
  int terminate() { return version == 2 ? fmi2Terminate(c) : fmi3Terminate(c); }
  int set_real(fmi2ValueReference r, double v) {
    return version == 2 ? fmi2SetReal(c, &r, 1, &v) : fmi3SetFloat64(c, &r, 1, &v, 1);
  }
  int set_int(fmi2ValueReference r, int v) {
    return version == 2 ? fmi2SetInteger(c, &r, 1, &v) : fmi3SetInt32(c, &r, 1, &v, 1);
  }
  int set_bool(fmi2ValueReference r, int v) {
    if (version == 2) return fmi2SetBoolean(c, &r, 1, &v);
    fmi3Boolean b = v != 0;
    return fmi3SetBoolean(c, &r, 1, &b, 1);
  }
  int get_real(fmi2ValueReference r, double& v) {
    return version == 2 ? fmi2GetReal(c, &r, 1, &v) : fmi3GetFloat64(c, &r, 1, &v, 1);
  }
  int get_int(const fmuglue::Variable& var, long long& v) {
    fmi2ValueReference r = var.vr;
    if (version == 2) {
      int x = 0;
      const int st = fmi2GetInteger(c, &r, 1, &x);
      v = x;
      return st;
    }
    if (!var.enumeration.empty()) {
      fmi3Int64 x = 0;
      const int st = fmi3GetInt64(c, &r, 1, &x, 1);
      v = x;
      return st;
    }
    fmi3Int32 x = 0;
    const int st = fmi3GetInt32(c, &r, 1, &x, 1);
    v = x;
    return st;
  }
  int get_bool(fmi2ValueReference r, int& v) {
    if (version == 2) return fmi2GetBoolean(c, &r, 1, &v);
    fmi3Boolean b = false;
    const int st = fmi3GetBoolean(c, &r, 1, &b, 1);
    v = b ? 1 : 0;
    return st;
  }
  int get_state(void** s) {
    return version == 2 ? fmi2GetFMUstate(c, reinterpret_cast<fmi2FMUstate*>(s))
                        : fmi3GetFMUState(c, reinterpret_cast<fmi3FMUState*>(s));
  }
  int set_state(void* s) { return version == 2 ? fmi2SetFMUstate(c, s) : fmi3SetFMUState(c, s); }
  int free_state(void** s) {
    return version == 2 ? fmi2FreeFMUstate(c, reinterpret_cast<fmi2FMUstate*>(s))
                        : fmi3FreeFMUState(c, reinterpret_cast<fmi3FMUState*>(s));
  }
  bool serialize(void* s, std::vector<std::uint8_t>& out) {
    size_t n = 0;
    if ((version == 2 ? fmi2SerializedFMUstateSize(c, s, &n) : fmi3SerializedFMUStateSize(c, s, &n)) != fmi2OK)
      return false;
    if (n > (1u << 24)) finding("serialized state size", "more than 16 MB");
    out.resize(n);
    return (version == 2 ? fmi2SerializeFMUstate(c, s, reinterpret_cast<fmi2Byte*>(out.data()), n)
                         : fmi3SerializeFMUState(c, s, out.data(), n)) == fmi2OK;
  }
  // de-serialize and set; the temporary state is freed
  int restore(const std::vector<std::uint8_t>& b) {
    void* s = nullptr;
    int st = version == 2
                 ? fmi2DeSerializeFMUstate(c, reinterpret_cast<const fmi2Byte*>(b.data()), b.size(),
                                           reinterpret_cast<fmi2FMUstate*>(&s))
                 : fmi3DeserializeFMUState(c, b.data(), b.size(), reinterpret_cast<fmi3FMUState*>(&s));
    if (st != fmi2OK) return st;
    st = set_state(s);
    free_state(&s);
    return st;
  }
};

// FNV-1a 64 with its published offset basis: the glue's state checksum (docs/fmu.md section 4).
std::uint64_t fnv1a64(const std::uint8_t* p, size_t n) {
  std::uint64_t h = 14695981039346656037ull;
  for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  return h;
}
void resign(std::vector<std::uint8_t>& b) {
  if (b.size() < 16) return;
  const std::uint64_t h = fnv1a64(b.data(), b.size() - 8);
  std::memcpy(b.data() + b.size() - 8, &h, 8);
}

bool has_bounds(const fmuglue::Variable& v) { return !std::isnan(v.min) && !std::isnan(v.max); }

struct DeepProgram {
  const fmuglue::ModelInfo& info = fmuglue::modelInfo();
  const std::string& guid = fmuglue::thisModelGuid();
  std::vector<const fmuglue::Variable*> params, tunables, inputs, outputs;
  Api a, b;              // b: where states are restored and compared
  double t = 0.0, start = 0.0;
  bool running = false;  // a is initialized and may step
  std::vector<void*> states;
  std::vector<std::uint8_t> blob;

  // Compact inputs (decoder byte bit 3): a step's inputs cost one byte (mostly the previous values
  // held, sometimes one input or all of them new), so that a program of the same length runs many
  // more steps on a model with many inputs (the 3D controller has 21: a step took 22 bytes or more,
  // and its programs averaged about 20 successful steps).
  bool compact = false;
  std::vector<double> held;

  explicit DeepProgram(int version, bool scheduled = false, bool compact_inputs = false) : compact(compact_inputs) {
    a.version = b.version = version;
    a.scheduled = b.scheduled = scheduled && version == 3 && info.clock.interval > 0.0;
    a.clock = b.clock = info.clock.vr;
    for (const auto& v : info.variables) {
      if (v.causality == fmuglue::Causality::Parameter && v.variability != fmuglue::Variability::Constant) {
        params.push_back(&v);
        if (v.variability == fmuglue::Variability::Tunable) tunables.push_back(&v);
      }
      if (v.causality == fmuglue::Causality::Input && v.type == fmuglue::Type::Real) inputs.push_back(&v);
      if (v.causality == fmuglue::Causality::Output) outputs.push_back(&v);
    }
  }

  // A parameter value: mostly the start value or inside the declared range, sometimes at a bound,
  // rarely outside it (the set must then be refused).
  static double param_value(const fmuglue::Variable& v, Bytes& in) {
    const std::uint8_t k = in.u8();
    const double lo = v.min, hi = v.max, s = v.start;
    if (v.type == fmuglue::Type::Boolean) return k % 17 == 0 ? 2.0 : double(k & 1);
    if (!has_bounds(v)) return k % 4 == 0 ? s * (0.5 + (in.u8() / 255.0)) : s;
    const double u = in.u8() / 255.0;
    double x;
    switch (k % 16) {
      case 0: case 1: case 2: case 3: case 4: case 5: x = s; break;
      case 6: x = lo; break;
      case 7: x = hi; break;
      case 8: case 9: case 10: x = lo + u * (hi - lo); break;
      case 11: case 12:  // log-uniform between the start value and a bound: values near the default
        x = (s > 0 && hi > s) ? s * std::pow(hi / s, u * u) : (s < 0 && lo < s) ? s * std::pow(lo / s, u * u) : s;
        break;
      case 13: x = s + (u - 0.5) * 0.1 * (hi - lo); break;
      case 14: x = k & 0x10 ? hi + (1.0 + hi - lo) * (0.01 + u) : lo - (1.0 + hi - lo) * (0.01 + u); break;  // outside
      default: x = in.real(); break;  // anything (NaN, denormals, 1e308 ...)
    }
    // an Integer's value as fmi2SetInteger can carry it (an "outside" value beyond int32 was clamped
    // by set_param into a range that ends at INT32_MAX, then counted as accepted outside it)
    if (v.type == fmuglue::Type::Integer) return std::isfinite(x) ? std::clamp(std::round(x), -2147483648.0, 2147483647.0) : 0.0;
    return x;
  }
  static bool allowed(const fmuglue::Variable& v, double x) {
    return std::isfinite(x) && (std::isnan(v.min) || x >= v.min) && (std::isnan(v.max) || x <= v.max);
  }
  int set_param(Api& api, const fmuglue::Variable& v, double x) {
    if (v.type == fmuglue::Type::Real) return api.set_real(v.vr, x);
    if (v.type == fmuglue::Type::Integer)
      return api.set_int(v.vr, static_cast<int>(x));  // param_value: integral, within int32
    if (v.type == fmuglue::Type::Boolean) return api.set_bool(v.vr, int(x));
    return fmi2OK;
  }

  // A plausible input value for the variable's unit; rarely a fault (NaN, Inf, huge).
  static double input_value(const fmuglue::Variable& v, Bytes& in, double phase) {
    const std::uint8_t k = in.u8();
    if (k == 255) return std::numeric_limits<double>::quiet_NaN();
    if (k == 254) return std::numeric_limits<double>::infinity();
    if (k == 253) return 1e30;
    const double u = (k / 252.0 - 0.5) * 2.0;  // [-1, 1]
    const double wave = std::sin(phase);
    if (v.unit == "rad") return v.start + 0.05 * u + 0.02 * wave;
    if (v.unit == "m") return v.start + 0.03 * u;
    if (v.unit == "N") {
      if (v.start > 1.0) return v.start * (1.0 + 0.1 * u);             // a normal force: the weight
      const std::uint8_t m = in.u8();                                    // a push: mostly none
      return m < 160 ? 0.0 : m < 250 ? 12.0 * u : 900.0 * u;
    }
    return v.start + u;
  }

  void free_states() {
    for (void*& s : states) a.free_state(&s);
    states.clear();
  }

  // Parameters that only cost time before the start, set to a short value inside their declared
  // range before anything else: the 3D plant's settle_time (1 s, 4 000 ODE steps of settling in
  // every initialization, made its deep programs spend most of their time there, issue 33). The
  // program's own parameter sets come after, so settle_time may still take its start value or any
  // other (param_value); a short settling leaves the robot still moving at the start, a state
  // its steps, restores and forgeries must handle all the same.
  void quick_start(Api& api) {
    static const NamedValue kQuick[] = {{"settle_time", 0.02}};
    set_named(api, kQuick);
  }

  // The parameters of `table` this model has, set to their values (each inside its declared range,
  // so a refusal is a finding).
  struct NamedValue {
    const char* name;
    double value;
  };
  template <std::size_t N>
  void set_named(Api& api, const NamedValue (&table)[N]) {
    for (const fmuglue::Variable* v : params)
      for (const NamedValue& q : table)
        if (v->name == q.name && allowed(*v, q.value) && set_param(api, *v, q.value) != fmi2OK)
          finding("parameter set", (v->name + " refused a value inside its range").c_str());
  }

  // A mode a model enters only on inputs the plausible ones never make, set (before the program's
  // own parameters) in the programs whose parameter-count byte says so: the 3D controller's stepping
  // layer, with a step started at a set time whatever the decision rules (step_trigger_time, 0.1 s
  // after the start), so that its phases (weight shift, swing, touch-down, transfer, settling, the
  // closing step) run under the programs' inputs, steps, restores and forgeries. A step is otherwise
  // decided only when the capture point leaves the feet, and the fuzzer never reached the layer's
  // step function (bash scripts/fuzz.sh: 0 of its 892 edges in 60 s).
  void stepping_mode(Api& api) {
    static const NamedValue kStepping[] = {{"stepping_enabled", 1.0}, {"step_trigger_time", 0.1}};
    set_named(api, kStepping);
  }

  // Instantiate (if needed), set parameters, initialize. False: the model refused them (the
  // program then re-initializes with the start values).
  bool initialize(Bytes& in) {
    if (!a.c && !a.instantiate("deep", guid, in.u8() & 1)) finding("instantiate", "the valid call returned NULL");
    quick_start(a);
    const std::uint8_t count = in.u8();
    if ((count / 6) % 3 == 1) stepping_mode(a);  // a third of the programs (the seeds' count bytes are below 6)
    const int n = count % 6;
    for (int i = 0; i < n && !params.empty(); ++i) {
      const fmuglue::Variable& v = *params[in.u8() % params.size()];
      const double x = param_value(v, in);
      const int st = set_param(a, v, x);
      if ((st == fmi2OK) != allowed(v, x) && v.type != fmuglue::Type::String)
        finding("parameter set", (v.name + (st == fmi2OK ? " accepted a value outside its range"
                                                        : " refused a value inside its range")).c_str());
    }
    static const double kStart[] = {0.0, 0.0, 0.0, 5.0, 1000.0, -2.0};
    start = kStart[in.u8() % 6];
    const std::uint8_t f = in.u8();
    if (a.enter(start, f % 5 == 0, start + 3.0) > fmi2Warning) finding("initialization", "enter refused");
    if (a.exit() > fmi2Warning) return false;
    t = start;
    running = true;
    return true;
  }
  void reinitialize_with_defaults(Bytes& in) {
    free_states();
    a.reset();
    running = false;
    quick_start(a);
    if (a.enter(0.0, false, 0.0) > fmi2Warning || a.exit() > fmi2Warning) finding("initialization", "defaults refused");
    t = start = 0.0;
    running = true;
    (void)in;
  }

  void set_inputs(Api& api, Bytes& in, double phase) {
    if (!compact) {
      for (const fmuglue::Variable* v : inputs) api.set_real(v->vr, input_value(*v, in, phase));
      return;
    }
    if (held.size() != inputs.size())
      for (const fmuglue::Variable* v : inputs) held.push_back(v->start);
    const std::uint8_t sel = in.u8();  // < 128: all held; < 224: one new; else all new
    for (size_t i = 0; i < inputs.size(); ++i)
      if (sel >= 224 || (sel >= 128 && i == sel % inputs.size())) held[i] = input_value(*inputs[i], in, phase);
    for (size_t i = 0; i < inputs.size(); ++i) api.set_real(inputs[i]->vr, held[i]);
  }

  // The step a program asks for, or the clock's interval for a Scheduled Execution instance.
  double h_of(double h) const { return a.scheduled ? info.clock.interval : h; }

  // One step of a; returns its status. A fall (Discard) ends the run: re-initialize.
  int step(Bytes& in, double h) {
    h = h_of(h);
    set_inputs(a, in, t * 7.0);
    const int st = a.step(t, h);
    ++g_deep.steps;
    if (st <= fmi2Warning) {
      t += h;
      ++g_deep.steps_ok;
    }
    return st;
  }
  static double step_size(Bytes& in) {
    static const double kH[] = {1e-3, 1e-3, 1e-3, 1e-3, 1e-3, 2.5e-3, 4e-4, 1e-2, 5e-2, 2e-3};
    return kH[in.u8() % 10];
  }

  // Every output of an instance, as bits (Real, Integer and Boolean), and whether all Reals are finite.
  bool outputs_of(Api& api, std::vector<std::uint64_t>& out) {
    out.clear();
    bool finite = true;
    for (const fmuglue::Variable* v : outputs) {
      std::uint64_t bits = 0;
      if (v->type == fmuglue::Type::Real) {
        double x = 0.0;
        if (api.get_real(v->vr, x) != fmi2OK) finding("get", v->name.c_str());
        finite = finite && std::isfinite(x);
        std::memcpy(&bits, &x, 8);
      } else if (v->type == fmuglue::Type::Integer) {
        long long x = 0;
        if (api.get_int(*v, x) != fmi2OK) finding("get", v->name.c_str());
        bits = static_cast<std::uint64_t>(x);
      } else if (v->type == fmuglue::Type::Boolean) {
        int x = 0;
        if (api.get_bool(v->vr, x) != fmi2OK) finding("get", v->name.c_str());
        bits = static_cast<std::uint64_t>(x);
      }
      out.push_back(bits);
    }
    if (api.version == 3) check_arrays(api);
    return finite;
  }

  // FMI 3.0 arrays (ModelInfo::arrays): each reads as its elements, bit for bit, and a wrong
  // nValues is refused.
  void check_arrays(Api& api) {
    for (const auto& arr : info.arrays) {
      const size_t n = arr.elements.size();
      std::vector<double> got(n + 1, 0.0), want(n, 0.0);
      fmi3ValueReference r = arr.vr;
      if (fmi3GetFloat64(api.c, &r, 1, got.data(), n) != fmi3OK) finding("array get", arr.name.c_str());
      for (size_t k = 0; k < n; ++k)
        if (api.get_real(arr.elements[k], want[k]) != fmi2OK) finding("array element get", arr.name.c_str());
      if (std::memcmp(got.data(), want.data(), n * sizeof(double)) != 0)
        finding("an array differs from its elements", arr.name.c_str());
      if (fmi3GetFloat64(api.c, &r, 1, got.data(), n + 1) == fmi3OK || fmi3GetFloat64(api.c, &r, 1, got.data(), 1) == fmi3OK)
        finding("array get with a wrong nValues accepted", arr.name.c_str());
    }
  }

  // a's state into b; both step k times on the same inputs and must stay bit-identical.
  void compare_restored(Bytes& in) {
    void* s = nullptr;
    if (a.get_state(&s) != fmi2OK) finding("fmi2GetFMUstate", "refused on an initialized instance");
    std::vector<std::uint8_t> bytes;
    if (!a.serialize(s, bytes)) finding("serialize", "refused a state of this instance");
    a.free_state(&s);
    if (!b.c && !b.instantiate("twin", guid, false)) finding("instantiate", "the twin");
    g_last_error.clear();
    if (b.restore(bytes) != fmi2OK) finding("a genuine serialized state was refused", g_last_error.c_str());
    ++g_deep.restores;
    const int k = 1 + in.u8() % 16;
    const double h = h_of(step_size(in));
    std::vector<std::uint64_t> oa, ob;
    for (int i = 0; i < k; ++i) {
      const std::vector<std::uint8_t> chunk = in.rest_chunk(compact ? 3 : inputs.size() * 2);
      Bytes ia(chunk.data(), chunk.size()), ib(chunk.data(), chunk.size());
      set_inputs(a, ia, t * 7.0);
      set_inputs(b, ib, t * 7.0);
      const int sa = a.step(t, h), sb = b.step(t, h);
      ++g_deep.steps;
      if (sa != sb) finding("restored state", "the restored instance's step status differs");
      outputs_of(a, oa);
      outputs_of(b, ob);
      if (oa != ob) {
        for (size_t j = 0; j < oa.size(); ++j)
          if (oa[j] != ob[j]) finding("restored state does not continue bit for bit", outputs[j]->name.c_str());
      }
      if (sa > fmi2Warning) {  // a fall or an error: both end their run (the twin is made anew)
        running = false;
        b.free();
        return;
      }
      ++g_deep.steps_ok;
      t += h;
    }
  }

  // A serialized state of a with one value replaced and the checksum recomputed, restored into
  // b: refused, or b behaves (its steps OK, Warning or Discard with finite outputs).
  void forge(Bytes& in) {
    void* s = nullptr;
    if (a.get_state(&s) != fmi2OK) return;
    std::vector<std::uint8_t> bytes;
    const bool ok = a.serialize(s, bytes);
    a.free_state(&s);
    if (!ok || bytes.size() < 64) return;
    const size_t header = 20 + (bytes[16] | (bytes[17] << 8)) + 24;
    if (bytes.size() < header + 24) return;
    const size_t span = bytes.size() - 8 - header - 8;
    const size_t pos = header + (in.u16() | (size_t(in.u8()) << 16)) % span;
    const std::uint8_t how = in.u8();
    if (how % 3 == 0) {
      const double x = in.real();
      std::memcpy(&bytes[pos], &x, 8);
    } else if (how % 3 == 1) {
      double x;  // a nearby value: scaled or shifted (plausible-looking forgeries)
      std::memcpy(&x, &bytes[pos], 8);
      x = how & 0x10 ? x * (1.0 + (in.u8() - 128) / 64.0) : x + (in.u8() - 128) * 1e-3;
      std::memcpy(&bytes[pos], &x, 8);
    } else {
      bytes[pos] = in.u8();
    }
    resign(bytes);
    ++g_deep.forged;
    // the twin, fresh: after a forged state it may be in any state, so it is freed after use
    if (!b.c && !b.instantiate("twin", guid, false)) finding("instantiate", "the twin");
    struct FreeTwin {
      Api& b;
      ~FreeTwin() { b.free(); }
    } free_twin{b};
    if (b.restore(bytes) != fmi2OK) return;
    ++g_deep.forged_accepted;
    double tb = 0.0;
    // the time it was restored to: the forged glue time may differ from a's
    if (b.version == 2) {
      if (fmi2GetRealStatus(b.c, fmi2LastSuccessfulTime, &tb) != fmi2OK) return;  // not a state that steps
    } else {
      fmi3ValueReference tv = fmuglue::kTimeValueReference;
      if (fmi3GetFloat64(b.c, &tv, 1, &tb, 1) != fmi3OK) return;
    }
    std::vector<std::uint64_t> ob;
    for (int i = 0; i < 3; ++i) {
      set_inputs(b, in, tb);
      g_last_error.clear();
      const int st = b.step(tb, h_of(1e-3));
      if (st == fmi2Discard) return;
      if (st > fmi2Warning) {
        // the glue refusing a step the restored state does not allow (it is terminated, failed or
        // at its stop time) is the right answer; any other error is a finding
        if (g_last_error.find("must not be called in state") != std::string::npos ||
            g_last_error.find("beyond the stop time") != std::string::npos)
          return;
        finding("forged state accepted, then its step failed", g_last_error.c_str());
      }
      if (!outputs_of(b, ob)) finding("forged state accepted", "a step returned a non-finite output");
      tb += h_of(1e-3);
    }
  }

  void run(Bytes& in) {
    ++g_deep.programs;
    if (!initialize(in)) reinitialize_with_defaults(in);
    int budget = 200;
    while (!in.empty() && budget-- > 0) {
      if (!running) reinitialize_with_defaults(in);
      const std::uint8_t op = in.u8();
      switch (op % 20) {
        default: {  // 0-9: a step of a plausible size
          const int st = step(in, step_size(in));
          if (st == fmi2Discard || st > fmi2Warning) running = false;
          break;
        }
        case 10: case 11: {  // a run of 1 ms steps
          const int k = 1 + in.u8() % 32;
          for (int i = 0; i < k && running; ++i) {
            const int st = step(in, 1e-3);
            if (st == fmi2Discard || st > fmi2Warning) running = false;
          }
          break;
        }
        case 12: {  // a tunable (or fixed, which must be refused) parameter changed while running
          if (params.empty()) break;
          const fmuglue::Variable& v = in.u8() & 1 && !tunables.empty() ? *tunables[in.u8() % tunables.size()]
                                                                        : *params[in.u8() % params.size()];
          const double x = param_value(v, in);
          const int st = set_param(a, v, x);
          if (st == fmi2OK && (v.variability != fmuglue::Variability::Tunable || !allowed(v, x)))
            finding("parameter set after initialization", (v.name + " accepted").c_str());
          break;
        }
        case 13: {  // get a state (keep up to 4)
          void* s = nullptr;
          if (a.get_state(&s) != fmi2OK) finding("fmi2GetFMUstate", "refused while running");
          states.push_back(s);
          if (states.size() > 4) {
            a.free_state(&states.front());
            states.erase(states.begin());
          }
          break;
        }
        case 14: {  // back to a state got earlier
          if (states.empty()) break;
          if (a.set_state(states[in.u8() % states.size()]) != fmi2OK) finding("fmi2SetFMUstate", "own state refused");
          double tt = 0.0;
          if (a.version == 2) fmi2GetRealStatus(a.c, fmi2LastSuccessfulTime, &tt);
          else {
            fmi3ValueReference tv = fmuglue::kTimeValueReference;
            fmi3GetFloat64(a.c, &tv, 1, &tt, 1);
          }
          t = tt;
          break;
        }
        case 15: case 16: compare_restored(in); break;
        case 17: forge(in); break;
        case 18: {  // reset and initialize anew (other parameters)
          free_states();
          if (a.reset() != fmi2OK) finding("reset", "refused");
          running = false;
          if (!initialize(in)) reinitialize_with_defaults(in);
          break;
        }
        case 19: {  // terminate, then reset
          a.terminate();
          free_states();
          running = false;
          break;
        }
      }
    }
    free_states();
    a.free();
    b.free();
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  const std::uint8_t mode = in.u8() % 4;
  if (mode == 0) {
    ShallowProgram p;
    p.run(in);
  } else {
    // FMI 3.0 programs of a model with a clock: every other one through Scheduled Execution
    DeepProgram p(mode == 2 ? 3 : 2, mode == 2 && (data[0] / 4) % 2 == 1, (data[0] & 8) != 0);
    p.run(in);
  }
  return 0;
}
