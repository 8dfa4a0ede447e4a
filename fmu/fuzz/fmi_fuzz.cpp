// Coverage-guided FMI 2.0 fuzzer (libFuzzer), one executable per FMU (<Model>_fuzz, built with
// -DANKLEHIP_FUZZ=ON, see docs/reliability.md). The fuzz input is decoded as a program of FMI
// calls on up to two instances of the FMU, linked in directly (the same glue and model objects as
// the shipped binary): instantiation with odd arguments, set-up and mode changes in any order,
// get/set of every type with valid and invalid value references, arrays of up to thousands of
// entries, special values (NaN, +-Inf, +-1e308, denormals, -0), steps of any size and at any
// time, FMU states got, set, freed, serialized and deserialized (bit-flipped, truncated, foreign,
// another instance's), reset, terminate, cancel, status queries with any kind, debug logging with
// unknown categories. Every input ends by freeing the instances (and with them the states still
// held), so LeakSanitizer sees every leak. A crash, a sanitizer report, a leak or a slow input
// (-timeout) is a finding.
//
// Input format (fmu/fuzz/make_seeds.py writes seeds in it): a sequence of operations, each an
// opcode byte followed by its argument bytes, read front to back; a missing byte reads as 0.
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
#include "fmuglue/glue.hpp"

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

void logger(fmi2ComponentEnvironment, fmi2String name, fmi2Status, fmi2String category, fmi2String message, ...) {
  // An importer's logger treats the message as a format: do the same (the glue escapes '%').
  char buf[2048];
  va_list ap;
  va_start(ap, message);
  std::vsnprintf(buf, sizeof buf, message ? message : "", ap);
  va_end(ap);
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

struct Program {
  Slot slot[2];
  std::vector<std::vector<std::uint8_t>> blobs;  // serialized states seen so far
  const fmuglue::ModelInfo& info = fmuglue::modelInfo();
  const std::string guid = fmuglue::modelGuid(info);

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
    for (int i = 0; i < k; ++i) {
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
          fmi2DoStep(c, t, h, (f >> 1) & 1);
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

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  Bytes in(data, size);
  Program p;
  p.run(in);
  return 0;
}
