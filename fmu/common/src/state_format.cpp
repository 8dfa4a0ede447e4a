// Versioned, checked byte format of FMU states (used for in-memory snapshots and serialization).
// Layout: see fmu/common/README.md section 3 and docs/fmu.md.
#include <cmath>
#include <cstring>

#include "instance.hpp"

namespace fmuglue {

static const char kMagic[8] = {'A', 'H', 'F', 'M', 'U', 'S', 'T', '1'};
static const std::uint32_t kFormatVersion = 3;  // 2: the last communication step size (the time rule's h); 3: FNV-1a-64's own offset basis

std::uint64_t fnv1a64(const void* p, std::size_t n, std::uint64_t h) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  for (std::size_t i = 0; i < n; ++i) {
    h ^= b[i];
    h *= 1099511628211ull;
  }
  return h;
}

struct Counts {
  std::uint32_t r = 0, i = 0, b = 0, s = 0;
};
static Counts countTypes(const ModelInfo& info) {
  Counts c;
  for (const auto& v : info.variables) {
    switch (v.type) {
      case Type::Real: ++c.r; break;
      case Type::Integer: ++c.i; break;
      case Type::Boolean: ++c.b; break;
      case Type::String: ++c.s; break;
    }
  }
  return c;
}

std::vector<std::uint8_t> encodeState(Instance& inst) {
  std::vector<std::uint8_t> payload;
  {
    StateWriter w(payload);
    w.u32(static_cast<std::uint32_t>(inst.state));
    w.f64(inst.time);
    w.f64(inst.startTime);
    w.f64(inst.stopTime);
    w.u32(inst.stopTimeDefined);
    w.f64(inst.tolerance);
    w.u32(inst.toleranceDefined);
    w.f64(inst.lastSuccessfulTime);
    w.f64(inst.lastStepSize);
    w.u32(inst.terminatedFlag);
    w.u32(inst.initDirty);
    for (size_t k = 0; k < inst.store.size(); ++k) {
      switch (inst.info.variables[k].type) {
        case Type::Real: w.f64(inst.store[k].r); break;
        case Type::Integer:
        case Type::Boolean: w.i32(inst.store[k].i); break;
        case Type::String: w.str(inst.store[k].s); break;
      }
    }
    std::vector<std::uint8_t> modelBytes;
    StateWriter mw(modelBytes);
    inst.model->save_state(mw);
    w.u64(modelBytes.size());
    w.bytes(modelBytes.data(), modelBytes.size());
  }
  std::vector<std::uint8_t> out;
  StateWriter w(out);
  w.bytes(kMagic, 8);
  w.u32(kFormatVersion);
  w.u32(inst.model->state_version());
  w.u32(static_cast<std::uint32_t>(inst.guid.size()));
  w.bytes(inst.guid.data(), inst.guid.size());
  Counts c = countTypes(inst.info);
  w.u32(c.r);
  w.u32(c.i);
  w.u32(c.b);
  w.u32(c.s);
  w.u64(payload.size());
  w.bytes(payload.data(), payload.size());
  w.u64(fnv1a64(out.data(), out.size()));
  return out;
}

bool decodeState(Instance& inst, const std::uint8_t* p, std::size_t n, std::string& err) {
  if (p == nullptr) { err = "state bytes are NULL"; return false; }
  if (n < 8 + 8) { err = "state is too short (" + std::to_string(n) + " bytes)"; return false; }
  if (std::memcmp(p, kMagic, 8) != 0) { err = "not a serialized FMU state of this glue (bad magic)"; return false; }
  std::uint64_t sum = 0;
  std::memcpy(&sum, p + n - 8, 8);
  StateReader r(p, n - 8);
  char magic[8];
  r.bytes(magic, 8);
  std::uint32_t fmt = 0, mver = 0, glen = 0;
  if (!r.u32(fmt) || fmt != kFormatVersion) { err = "unsupported state format version " + std::to_string(fmt); return false; }
  if (!r.u32(mver)) { err = "truncated state header"; return false; }
  if (!r.u32(glen) || glen > 256 || glen > r.remaining()) { err = "truncated or corrupt state header (GUID)"; return false; }
  std::string g(glen, '\0');
  r.bytes(&g[0], glen);
  if (g != inst.guid) { err = "state belongs to another model (GUID " + g + ", expected " + inst.guid + ")"; return false; }
  if (mver != inst.model->state_version()) {
    err = "model state version " + std::to_string(mver) + " != " + std::to_string(inst.model->state_version());
    return false;
  }
  Counts c = countTypes(inst.info), cs;
  if (!r.u32(cs.r) || !r.u32(cs.i) || !r.u32(cs.b) || !r.u32(cs.s)) { err = "truncated state header (counts)"; return false; }
  if (cs.r != c.r || cs.i != c.i || cs.b != c.b || cs.s != c.s) { err = "variable counts do not match this model"; return false; }
  std::uint64_t plen = 0;
  if (!r.u64(plen) || plen != r.remaining()) {
    err = "state length mismatch (truncated or padded: payload " + std::to_string(plen) + " bytes, " +
          std::to_string(r.remaining()) + " present)";
    return false;
  }
  if (fnv1a64(p, n - 8) != sum) { err = "state checksum mismatch (corrupted bytes)"; return false; }

  // Decode the glue part into temporaries.
  std::uint32_t st = 0, stopDef = 0, tolDef = 0, term = 0, dirty = 0;
  double time = 0, start = 0, stop = 0, tol = 0, lst = 0, lastStep = 0;
  bool ok = r.u32(st) && r.f64(time) && r.f64(start) && r.f64(stop) && r.u32(stopDef) && r.f64(tol) &&
            r.u32(tolDef) && r.f64(lst) && r.f64(lastStep) && r.u32(term) && r.u32(dirty);
  const unsigned validStates = static_cast<unsigned>(State::Instantiated) |
                               static_cast<unsigned>(State::InitializationMode) |
                               static_cast<unsigned>(State::StepComplete) |
                               static_cast<unsigned>(State::StepFailed) |
                               static_cast<unsigned>(State::StepCanceled) |
                               static_cast<unsigned>(State::Terminated);
  if (!ok || st == 0 || (st & (st - 1)) != 0 || (st & validStates) == 0) { err = "corrupt state payload (instance state)"; return false; }
  std::vector<Value> store(inst.store.size());
  for (size_t k = 0; k < store.size() && ok; ++k) {
    switch (inst.info.variables[k].type) {
      case Type::Real: ok = r.f64(store[k].r); break;
      case Type::Integer:
      case Type::Boolean: {
        std::int32_t v = 0;
        ok = r.i32(v);
        store[k].i = v;
        break;
      }
      case Type::String: ok = r.str(store[k].s); break;
    }
  }
  std::uint64_t mlen = 0;
  if (!ok || !r.u64(mlen) || mlen != r.remaining()) { err = "corrupt state payload (values)"; return false; }
  // A checksum only catches accidents: a state is validated like the calls that would have made it.
  // a defined stop time at or after the time (a step never passes it: doStep's rule)
  const bool stopOk = stopDef == 0 || (std::isfinite(stop) && stop >= start &&
                                       (time <= stop || timesMatch(time, stop, lastStep)));
  const bool tolOk = tolDef == 0 || (std::isfinite(tol) && tol > 0.0);
  if (!std::isfinite(time) || !std::isfinite(start) || time < start || lst != time ||
      !(lastStep >= 0.0 && lastStep <= time - start + timeTolerance(time, 0.0)) ||
      !stopOk || !tolOk || stopDef > 1 || tolDef > 1 || term > 1 || dirty > 1) {
    err = "corrupt state payload (experiment set-up or time)";
    return false;
  }
  for (size_t k = 0; k < store.size(); ++k) {
    const Variable& v = inst.info.variables[k];
    std::string why;
    if (v.type == Type::String) continue;
    const double x = v.type == Type::Real ? store[k].r : static_cast<double>(store[k].i);
    const bool calculated = v.causality == Causality::Output || v.causality == Causality::Local ||
                            v.causality == Causality::CalculatedParameter;
    if (!valueAllowed(v, x, why) || (calculated && !std::isfinite(x))) {
      err = "corrupt state payload: " + (why.empty() ? "\"" + v.name + "\" is not finite" : why);
      return false;
    }
  }
  StateReader mr(p + (n - 8 - r.remaining()), static_cast<size_t>(mlen));
  std::string merr;
  std::vector<std::uint8_t> backup;
  StateWriter bw(backup);
  inst.model->save_state(bw);
  // The model reads its parameters and checks its time against the restored instance: apply the
  // glue's part first, and put everything back if the model refuses its part.
  struct GluePart {
    State state;
    double time, startTime, stopTime, tolerance, lastSuccessfulTime, lastStepSize;
    bool stopTimeDefined, toleranceDefined, terminatedFlag, initDirty;
    std::vector<Value> store;
  };
  auto swap = [&inst](GluePart& g) {
    std::swap(inst.state, g.state);
    std::swap(inst.time, g.time);
    std::swap(inst.startTime, g.startTime);
    std::swap(inst.stopTime, g.stopTime);
    std::swap(inst.tolerance, g.tolerance);
    std::swap(inst.lastSuccessfulTime, g.lastSuccessfulTime);
    std::swap(inst.lastStepSize, g.lastStepSize);
    std::swap(inst.stopTimeDefined, g.stopTimeDefined);
    std::swap(inst.toleranceDefined, g.toleranceDefined);
    std::swap(inst.terminatedFlag, g.terminatedFlag);
    std::swap(inst.initDirty, g.initDirty);
    std::swap(inst.store, g.store);
  };
  GluePart restored{static_cast<State>(st), time, start, stop, tol, lst, lastStep, stopDef != 0, tolDef != 0, term != 0,
                    dirty != 0, std::move(store)};
  swap(restored);  // `restored` now holds the instance's previous glue part
  const bool loaded = inst.model->load_state(inst.ctx, mr, merr);
  if (!loaded || !mr.at_end()) {
    swap(restored);
    if (loaded) {  // undo the model's part too
      StateReader br(backup.data(), backup.size());
      std::string ignore;
      inst.model->load_state(inst.ctx, br, ignore);
    }
    err = loaded ? "model state has trailing bytes" : "model state rejected: " + merr;
    return false;
  }
  return true;
}

}  // namespace fmuglue
