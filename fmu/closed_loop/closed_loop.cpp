// libanklehip_closed_loop: the closed-loop master of anklehip.master in C++, for
// `anklehip run --engine native` and the sweeps (anklehip/native.py calls it through ctypes).
//
// Loads both FMUs' binaries with dlopen (fmu/importer), instantiates and initializes them the way
// FMPy does (setupExperiment, parameters, enter/exit initialization mode), and runs the same
// Gauss-Seidel loop over the same preallocated result rows as the Python master: per step k,
//   plant outputs(t_k) -> controller inputs -> controller doStep(t_k, h) -> controller outputs
//   -> plant inputs (+ the push columns the caller filled) -> plant doStep(t_k, h).
// The same calls with the same arguments in the same order: the rows are bit-identical to the
// FMPy master's. Outcome decisions and messages stay in Python (master.py): this returns the raw
// facts (the failing step, the statuses, the plant's terminated flag and last successful time).
//
// ahn_write_csv writes a table in FMPy's write_csv layout (quoted header; numbers as Python's
// repr of a float / str of an integer, i.e. the shortest round-trip digits), byte for byte.
#include <charconv>
#include <chrono>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <algorithm>
#include <string>
#include <thread>
#include <vector>

#include "fmi2Functions.h"
#include "fmu_library.hpp"

extern "C" {

// One FMU: where it is unpacked, and the parameter values to set before initialization.
struct ahn_fmu {
  const char* unzipdir;
  const char* model_identifier;
  const char* guid;
  const char* instance_name;
  int32_t n_params;
  const uint32_t* param_vr;
  const char* param_kind;  // per parameter: 'R' real, 'I' integer, 'B' boolean, 'S' string
  const double* param_real;
  const int32_t* param_int;
  const char* const* param_str;
};

// The master's column layout (anklehip.master._Layout) as value-reference arrays and row offsets.
struct ahn_layout {
  const uint32_t *p_real, *p_int, *p_bool, *c_in, *c_feed, *c_other, *c_int, *c_bool, *p_in;
  int32_t n_p_real, n_p_int, n_p_bool, n_c_in, n_c_feed, n_c_other, n_c_int, n_c_bool, n_p_in;
  int32_t off_feed, off_cother, off_pbool, off_cint, off_cbool;  // within a row of R / of I
  int32_t n_real, n_int;                                           // row lengths of R / I
};

struct ahn_run {
  ahn_fmu controller, plant;
  ahn_layout layout;
  double t0, h, stop_time;
  int64_t n_steps;
  double* R;   // (n_steps + 1) x n_real, the push columns filled by the caller
  int32_t* I;  // (n_steps + 1) x n_int
  double* c_init_real;   // the controller's c_feed + c_other values after initialization
  int32_t* c_init_int;   // its c_int + c_bool values
  int32_t log_errors;    // print the FMUs' warning and error messages on stderr
  // results
  int32_t setup_failed;       // 1: loading or initialization failed (message says why)
  int64_t failed_at;          // step whose calls failed, -1 when all N steps ran
  int32_t status_ctrl, status_plant, status_io;  // fmi2DoStep of each, OR of the get/set calls
  int32_t plant_terminated;   // after a failed plant step: fmi2Terminated status (-1 unknown)
  double plant_last_time;     // ... fmi2LastSuccessfulTime (NaN unknown)
  double wall_seconds;        // of the loop
  char message[1024];
};

int ahn_run_closed_loop(ahn_run* r);
int ahn_write_csv(const char* path, int32_t n_cols, const char* const* names, const char* kinds,
                  const void* const* columns, const int64_t* strides, int64_t n_rows, char* err, int32_t err_len);
}

namespace {

struct Instance;
void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
            fmi2String message, ...);

struct Instance {
  void* lib = nullptr;
  fmuimport::Fmi2Api api;
  fmi2Component c = nullptr;
  fmi2CallbackFunctions callbacks{};
  bool print_errors = false;
  std::string errors;  // the FMU's error messages, in order (named in a failed set-up's message)

  ~Instance() {
    if (c) api.freeInstance(c);
    if (lib) fmuimport::closeLibrary(lib);
  }

  // Load, instantiate, set up and initialize as anklehip.fmu.Slave does; false with `err`.
  bool start(const ahn_fmu& f, double t0, double stop, bool log_errors, std::string& err) {
    const std::string so = fmuimport::binaryPath(f.unzipdir, f.model_identifier);
    lib = fmuimport::openLibrary(so, err);
    if (!lib) return err = "loading " + so + ": " + err, false;
    if (!api.load(lib, err)) return err = so + ": " + err, false;
    callbacks.logger = logger;
    callbacks.allocateMemory = std::calloc;
    callbacks.freeMemory = std::free;
    callbacks.componentEnvironment = this;
    print_errors = log_errors;
    const std::string uri = std::string("file://") + f.unzipdir + "/resources";
    c = api.instantiate(f.instance_name, fmi2CoSimulation, f.guid, uri.c_str(), &callbacks, fmi2False, fmi2False);
    if (!c) return err = std::string(f.model_identifier) + ": fmi2Instantiate failed" + why(), false;
    if (api.setupExperiment(c, fmi2False, 0.0, t0, fmi2True, stop) > fmi2Warning)
      return err = std::string(f.model_identifier) + ": fmi2SetupExperiment failed" + why(), false;
    for (int i = 0; i < f.n_params; ++i) {
      const fmi2ValueReference vr = f.param_vr[i];
      fmi2Status s = fmi2OK;
      switch (f.param_kind[i]) {
        case 'R': s = api.setReal(c, &vr, 1, &f.param_real[i]); break;
        case 'I': s = api.setInteger(c, &vr, 1, &f.param_int[i]); break;
        case 'B': { const fmi2Boolean b = f.param_int[i] ? fmi2True : fmi2False; s = api.setBoolean(c, &vr, 1, &b); break; }
        case 'S': s = api.setString(c, &vr, 1, &f.param_str[i]); break;
        default: return err = "parameter kind " + std::string(1, f.param_kind[i]) + " unknown", false;
      }
      if (s > fmi2Warning)
        return err = std::string(f.model_identifier) + " refused the parameter with value reference " +
                     std::to_string(vr) + why(), false;
    }
    if (api.enterInitializationMode(c) > fmi2Warning || api.exitInitializationMode(c) > fmi2Warning)
      return err = std::string(f.model_identifier) + ": initialization failed" + why(), false;
    return true;
  }

  std::string why() const { return errors.empty() ? "" : ": " + errors; }

  void stop(bool terminate) {
    if (!c) return;
    if (terminate) api.terminate(c);
    api.freeInstance(c);
    c = nullptr;
  }
};

void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
            fmi2String message, ...) {
  if (!env || status < fmi2Warning) return;
  auto* inst = static_cast<Instance*>(env);
  static const char* const kStatus[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
  char buf[2048];
  va_list ap;
  va_start(ap, message);
  std::vsnprintf(buf, sizeof buf, message ? message : "", ap);
  va_end(ap);
  if (status >= fmi2Error) inst->errors += (inst->errors.empty() ? "" : "; ") + std::string(buf);
  if (inst->print_errors)
    std::fprintf(stderr, "[%s] %s %s: %s\n", kStatus[status <= fmi2Pending ? status : fmi2Pending],
                 instance ? instance : "?", category ? category : "", buf);
}

// Python's repr of a float (which FMPy's write_csv prints through numpy's str): the shortest
// digits that round-trip, positional for 1e-4 <= |x| < 1e16 (with ".0" when integral), else
// d.ddde[+-]XX. Writes into p (at least 32 bytes), returns the end.
char* format_float(char* p, double x) {
  if (std::isnan(x)) return std::memcpy(p, "nan", 3), p + 3;
  if (std::isinf(x)) return x < 0 ? (std::memcpy(p, "-inf", 4), p + 4) : (std::memcpy(p, "inf", 3), p + 3);
  char s[32];
  char* end = std::to_chars(s, s + sizeof s, x, std::chars_format::scientific).ptr;
  const char* q = s;
  if (*q == '-') *p++ = *q++;
  char digits[20];  // at most 17 significant digits
  int n = 0;
  for (; *q != 'e'; ++q)
    if (*q != '.') digits[n++] = *q;
  int exp10 = 0;
  std::from_chars(q[1] == '+' ? q + 2 : q + 1, end, exp10);
  if (exp10 >= -4 && exp10 < 16) {
    if (exp10 < 0) {
      *p++ = '0';
      *p++ = '.';
      for (int i = 0; i < -exp10 - 1; ++i) *p++ = '0';
      std::memcpy(p, digits, static_cast<size_t>(n));
      return p + n;
    }
    if (n <= exp10 + 1) {
      std::memcpy(p, digits, static_cast<size_t>(n));
      p += n;
      for (int i = n; i < exp10 + 1; ++i) *p++ = '0';
      return std::memcpy(p, ".0", 2), p + 2;
    }
    std::memcpy(p, digits, static_cast<size_t>(exp10 + 1));
    p += exp10 + 1;
    *p++ = '.';
    std::memcpy(p, digits + exp10 + 1, static_cast<size_t>(n - exp10 - 1));
    return p + (n - exp10 - 1);
  }
  *p++ = digits[0];
  if (n > 1) {
    *p++ = '.';
    std::memcpy(p, digits + 1, static_cast<size_t>(n - 1));
    p += n - 1;
  }
  *p++ = 'e';
  *p++ = exp10 < 0 ? '-' : '+';
  const int e = exp10 < 0 ? -exp10 : exp10;
  if (e < 10) *p++ = '0';
  return std::to_chars(p, p + 4, e).ptr;
}

}  // namespace

int ahn_run_closed_loop(ahn_run* r) {
  const ahn_layout& L = r->layout;
  r->setup_failed = 0;
  r->failed_at = -1;
  r->status_ctrl = r->status_plant = r->status_io = 0;
  r->plant_terminated = -1;
  r->plant_last_time = NAN;
  r->message[0] = '\0';
  auto fail = [&](const std::string& why) {
    std::snprintf(r->message, sizeof r->message, "%s", why.c_str());
    r->setup_failed = 1;
    return 1;
  };
  Instance ctrl, plant;
  std::string err;
  if (!ctrl.start(r->controller, r->t0, r->stop_time, r->log_errors, err)) return fail(err);
  if (!plant.start(r->plant, r->t0, r->stop_time, r->log_errors, err)) return fail(err);
  // the controller's outputs after initialization (RunResult.controller_initial)
  ctrl.api.getReal(ctrl.c, L.c_feed, L.n_c_feed, r->c_init_real);
  ctrl.api.getReal(ctrl.c, L.c_other, L.n_c_other, r->c_init_real + L.n_c_feed);
  ctrl.api.getInteger(ctrl.c, L.c_int, L.n_c_int, r->c_init_int);
  ctrl.api.getBoolean(ctrl.c, L.c_bool, L.n_c_bool, r->c_init_int + L.n_c_int);

  const fmuimport::Fmi2Api &P = plant.api, &C = ctrl.api;
  const fmi2Component pc = plant.c, cc = ctrl.c;
  const int64_t N = r->n_steps;
  const double h = r->h, t0 = r->t0;
  int sc = 0, sp = 0, st = 0;
  const auto wall0 = std::chrono::steady_clock::now();
  int64_t j = 0;
  for (; j < N; ++j) {
    const double t = t0 + static_cast<double>(j) * h;
    double* rR = r->R + j * L.n_real;
    int32_t* rI = r->I + j * L.n_int;
    st = P.getReal(pc, L.p_real, L.n_p_real, rR);
    if (L.n_p_int) st |= P.getInteger(pc, L.p_int, L.n_p_int, rI);
    if (L.n_p_bool) st |= P.getBoolean(pc, L.p_bool, L.n_p_bool, rI + L.off_pbool);
    st |= C.setReal(cc, L.c_in, L.n_c_in, rR);
    sc = C.doStep(cc, t, h, fmi2True);
    st |= C.getReal(cc, L.c_feed, L.n_c_feed, rR + L.off_feed);
    if (L.n_c_other) st |= C.getReal(cc, L.c_other, L.n_c_other, rR + L.off_cother);
    if (L.n_c_int) st |= C.getInteger(cc, L.c_int, L.n_c_int, rI + L.off_cint);
    if (L.n_c_bool) st |= C.getBoolean(cc, L.c_bool, L.n_c_bool, rI + L.off_cbool);
    st |= P.setReal(pc, L.p_in, L.n_p_in, rR + L.off_feed);
    sp = P.doStep(pc, t, h, fmi2True);
    if (sp > fmi2Warning || sc > fmi2Warning || st > fmi2Warning) break;
  }
  r->wall_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - wall0).count();
  r->status_ctrl = sc;
  r->status_plant = sp;
  r->status_io = st;
  // the plant's outputs at the end (stop time, or its last successful time) close the record,
  // after the controller and push columns of the row before
  const int64_t last = j < N ? j + 1 : N;
  if (j < N) {
    r->failed_at = j;
    fmi2Boolean term = fmi2False;
    if (P.getBooleanStatus(pc, fmi2Terminated, &term) <= fmi2Warning) r->plant_terminated = term ? 1 : 0;
    double tl = NAN;
    if (P.getRealStatus(pc, fmi2LastSuccessfulTime, &tl) <= fmi2Warning) r->plant_last_time = tl;
  }
  // (as master.py: not after a controller failure, a failed get/set, or a plant error)
  if (j == N || (sc <= fmi2Warning && sp == fmi2Discard)) {
    const int64_t prev = last - 1;
    std::memcpy(r->R + last * L.n_real, r->R + prev * L.n_real, sizeof(double) * L.n_real);
    std::memcpy(r->I + last * L.n_int, r->I + prev * L.n_int, sizeof(int32_t) * L.n_int);
    P.getReal(pc, L.p_real, L.n_p_real, r->R + last * L.n_real);
    if (L.n_p_int) P.getInteger(pc, L.p_int, L.n_p_int, r->I + last * L.n_int);
    if (L.n_p_bool) P.getBoolean(pc, L.p_bool, L.n_p_bool, r->I + last * L.n_int + L.off_pbool);
  }
  const bool completed = j == N;
  plant.stop(completed);
  ctrl.stop(completed);
  return 0;
}

int ahn_write_csv(const char* path, int32_t n_cols, const char* const* names, const char* kinds,
                  const void* const* columns, const int64_t* strides, int64_t n_rows, char* err, int32_t err_len) {
  // On failure: the reason (strerror) in err and errno as the result (a full disk: ENOSPC), so the
  // caller can name the file and the reason.
  FILE* f = std::fopen(path, "wb");
  if (!f) {
    const int e = errno ? errno : EIO;
    std::snprintf(err, static_cast<size_t>(err_len), "%s", std::strerror(e));
    return e;
  }
  int first_errno = 0;
  std::string head;
  for (int c = 0; c < n_cols; ++c) {
    if (c) head += ',';
    head += '"';
    head += names[c];
    head += '"';
  }
  head += '\n';
  bool ok = std::fwrite(head.data(), 1, head.size(), f) == head.size();
  // Rows are formatted in blocks, two at a time on two threads where the machine has two cores,
  // and written in order.
  auto format_block = [&](int64_t first, int64_t end, std::vector<char>& buf) {
    buf.resize(static_cast<size_t>(end - first) * (static_cast<size_t>(n_cols) * 33 + 2));
    char* p = buf.data();
    for (int64_t i = first; i < end; ++i) {
      for (int c = 0; c < n_cols; ++c) {
        if (c) *p++ = ',';
        const char* src = static_cast<const char*>(columns[c]) + i * strides[c];
        if (kinds[c] == 'f') {
          double x;
          std::memcpy(&x, src, sizeof x);
          p = format_float(p, x);
        } else {
          int32_t v;
          std::memcpy(&v, src, sizeof v);
          p = std::to_chars(p, p + 12, v).ptr;
        }
      }
      *p++ = '\n';
    }
    buf.resize(static_cast<size_t>(p - buf.data()));
  };
  constexpr int64_t kBlock = 2048;
  const bool two = std::thread::hardware_concurrency() > 1 && n_rows > kBlock;
  std::vector<char> buf[2];
  for (int64_t r = 0; r < n_rows && ok; r += (two ? 2 : 1) * kBlock) {
    const int64_t e0 = std::min(n_rows, r + kBlock), e1 = std::min(n_rows, e0 + kBlock);
    std::thread second;
    if (two && e0 < e1) second = std::thread(format_block, e0, e1, std::ref(buf[1]));
    format_block(r, e0, buf[0]);
    ok = std::fwrite(buf[0].data(), 1, buf[0].size(), f) == buf[0].size();
    if (second.joinable()) {
      second.join();
      ok = ok && std::fwrite(buf[1].data(), 1, buf[1].size(), f) == buf[1].size();
    }
    if (!ok && !first_errno) first_errno = errno;
  }
  if (!ok && !first_errno) first_errno = errno;
  if (std::fclose(f) != 0) {
    if (ok) first_errno = errno;
    ok = false;
  }
  if (ok) return 0;
  const int e = first_errno ? first_errno : EIO;
  std::snprintf(err, static_cast<size_t>(err_len), "%s", std::strerror(e));
  return e;
}
