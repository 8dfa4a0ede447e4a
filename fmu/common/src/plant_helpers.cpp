// Shared doStep rules of the plant FMUs (glue.hpp, "Helpers for plant models").
#include <algorithm>
#include <cmath>

#include "fmuglue/glue.hpp"

namespace fmuglue {

fmi2Status readFiniteInputs(Context& ctx, double t, int n, const fmi2ValueReference* vrs,
                            const char* const* names, double* last, double* in, fmi2ValueReference fault_vr) {
  const unsigned before = static_cast<unsigned>(ctx.integer(fault_vr));  // the mask of the last step
  unsigned held = 0;
  for (int i = 0; i < n; ++i) {
    const unsigned bit = 1u << i;
    in[i] = ctx.real(vrs[i]);
    if (!std::isfinite(in[i])) {  // contained: hold the last finite value
      if (!(before & bit))
        ctx.log(kLogStatusWarning, fmi2Warning, "t=%g: input %s = %g is not finite; holding %g (input_fault bit %d)",
                t, names[i], in[i], last[i], i);
      in[i] = last[i];
      held |= bit;
    } else if (before & bit) {
      ctx.log(kLogEvents, fmi2OK, "t=%g: input %s finite again (%g)", t, names[i], in[i]);
    }
    last[i] = in[i];
  }
  ctx.set_integer(fault_vr, static_cast<int>(held));
  return held ? fmi2Warning : fmi2OK;
}

StepResult plantStepResult(Context& ctx, PlantOutcome outcome, fmi2Status ok_status, double fall_time,
                           const std::string& message) {
  StepResult res;
  switch (outcome) {
    case PlantOutcome::Ok:
      res.status = ok_status;
      return res;
    case PlantOutcome::Fallen:
      ctx.log(kLogStatusDiscard, fmi2Discard, "%s", message.c_str());
      res.status = fmi2Discard;
      res.last_successful_time = fall_time;
      res.terminated = true;
      return res;
    case PlantOutcome::Error:
      break;
  }
  ctx.log(kLogStatusError, fmi2Error, "plant step failed: %s", message.c_str());
  res.status = fmi2Error;
  return res;
}

bool plantMayStep(Context& ctx, bool initialized, double t, double h, double plant_time, bool fallen, double fall_time,
                  StepResult& res) {
  res = StepResult();
  if (!initialized) {
    ctx.log(kLogStatusError, fmi2Error, "doStep without an initialized plant");
    res.status = fmi2Error;
    return false;
  }
  if (!timesMatch(t, plant_time, h)) {  // the glue's rule (glue.hpp): the plant's time is the summed steps
    ctx.log(kLogStatusError, fmi2Error, "doStep at t=%.17g but the plant is at t=%.17g (tolerance %.3g s)", t,
            plant_time, timeTolerance(plant_time, h));
    res.status = fmi2Error;
    return false;
  }
  if (!(plantStepTo(t, h, plant_time) > 0.0)) {
    ctx.log(kLogStatusError, fmi2Error, "doStep(t=%.17g, h=%.17g) ends before the plant's time %.17g", t, h, plant_time);
    res.status = fmi2Error;
    return false;
  }
  if (fallen) {
    res.status = fmi2Discard;
    res.last_successful_time = fall_time;
    res.terminated = true;
    ctx.log(kLogStatusDiscard, fmi2Discard, "the robot has fallen at t=%g s; no further steps", fall_time);
    return false;
  }
  return true;
}

std::vector<double> initialKey(const Context& ctx) {
  std::vector<double> key = {ctx.start_time(), ctx.tolerance_defined() ? 1.0 : 0.0, ctx.tolerance()};
  for (const Variable& v : ctx.info().variables) {
    if (v.causality != Causality::Parameter) continue;
    switch (v.type) {
      case Type::Real: key.push_back(ctx.real(v.vr)); break;
      case Type::Integer: key.push_back(ctx.integer(v.vr)); break;
      case Type::Boolean: key.push_back(ctx.boolean(v.vr) ? 1.0 : 0.0); break;
      case Type::String: break;
    }
  }
  return key;
}

}  // namespace fmuglue
