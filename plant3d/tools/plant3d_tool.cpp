// plant3d_tool: inspect and drive the 3D plant without an FMI importer.
//
//   plant3d_tool describe                  the assembled ODE model (bodies, joints) as JSON
//   plant3d_tool run [options]             simulate with the joints held; CSV on stdout
//     --duration T     simulated time [s] (default 2)
//     --h H            communication step [s] (default 0.001)
//     --push F         push on the trunk, x [N] (default 0); --push-y F likewise in y
//     --push-from T0 --push-to T1   push window [s] (default: always)
//     --ramp R         push growing at R N/s from --push-from (instead of a step)
//     --set NAME=V     a parameter: mu, contact_stiffness, contact_damping, internal_step, rocking_step,
//                      h_push, theta_ankle_init, theta_hip_init, settle_time, kp_ankle, kd_ankle,
//                      kp_hip, kd_hip (repeatable)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <string>

#include "hoap2plant3d/plant3d.hpp"

using namespace hoap2plant3d;

namespace {

void print3(const double* v) { std::printf("[%.17g, %.17g, %.17g]", v[0], v[1], v[2]); }

int describe() {
  Plant3D plant(default_params());
  std::printf("{\"bodies\": [\n");
  const auto b = plant.bodies();
  for (size_t i = 0; i < b.size(); ++i) {
    std::printf("  {\"name\": \"%s\", \"proto\": \"%s\", \"mass\": %.17g, \"com\": ", b[i].name.c_str(),
                b[i].proto.c_str(), b[i].mass);
    print3(b[i].com);
    std::printf(", \"inertia\": [%.17g, %.17g, %.17g, %.17g, %.17g, %.17g]}%s\n", b[i].inertia[0], b[i].inertia[1],
                b[i].inertia[2], b[i].inertia[3], b[i].inertia[4], b[i].inertia[5], i + 1 < b.size() ? "," : "");
  }
  std::printf("], \"joints\": [\n");
  const auto j = plant.joints();
  for (size_t i = 0; i < j.size(); ++i) {
    std::printf("  {\"name\": \"%s\", \"proto\": \"%s\", \"anchor\": ", j[i].name.c_str(), j[i].proto.c_str());
    print3(j[i].anchor);
    std::printf(", \"axis\": ");
    print3(j[i].axis);
    std::printf(", \"lo\": %.17g, \"hi\": %.17g}%s\n", j[i].lo, j[i].hi, i + 1 < j.size() ? "," : "");
  }
  std::printf("]}\n");
  return 0;
}

bool set_param(Params& p, const std::string& name, double v) {
  const std::map<std::string, double*> reals = {
      {"mu", &p.mu}, {"contact_stiffness", &p.contact_stiffness}, {"contact_damping", &p.contact_damping},
      {"internal_step", &p.internal_step}, {"rocking_step", &p.rocking_step}, {"h_push", &p.h_push}, {"theta_ankle_init", &p.theta_ankle_init},
      {"theta_hip_init", &p.theta_hip_init}, {"settle_time", &p.settle_time},
      {"kp_ankle", &p.servo[AnklePitch].kp}, {"kd_ankle", &p.servo[AnklePitch].kd},
      {"kp_hip", &p.servo[HipPitch].kp}, {"kd_hip", &p.servo[HipPitch].kd},
      {"fall_foot_pitch", &p.fall_foot_pitch}, {"fall_body_pitch", &p.fall_body_pitch}};
  auto it = reals.find(name);
  if (it == reals.end()) return false;
  *it->second = v;
  return true;
}

int run(int argc, char** argv) {
  Params p = default_params();
  double duration = 2, h = 1e-3, push = 0, push_y = 0, t0 = -1e300, t1 = 1e300, ramp = 0;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> double {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "plant3d_tool: %s needs a value\n", a.c_str());
        std::exit(2);
      }
      return std::atof(argv[++i]);
    };
    if (a == "--duration") duration = next();
    else if (a == "--h") h = next();
    else if (a == "--push") push = next();
    else if (a == "--push-y") push_y = next();
    else if (a == "--push-from") t0 = next();
    else if (a == "--push-to") t1 = next();
    else if (a == "--ramp") ramp = next();
    else if (a == "--set" && i + 1 < argc) {
      const std::string kv = argv[++i];
      const auto eq = kv.find('=');
      if (eq == std::string::npos || !set_param(p, kv.substr(0, eq), std::atof(kv.c_str() + eq + 1))) {
        std::fprintf(stderr, "plant3d_tool: unknown --set %s\n", kv.c_str());
        return 2;
      }
    } else {
      std::fprintf(stderr, "plant3d_tool: unknown option %s\n", a.c_str());
      return 2;
    }
  }
  Plant3D plant(p);
  if (!plant.initialize(0.0)) {
    std::fprintf(stderr, "plant3d_tool: initialize: %s\n", plant.message().c_str());
    return 1;
  }
  Inputs in;
  in.ref[AnklePitch] = p.theta_ankle_init;
  in.ref[HipPitch] = p.theta_hip_init;
  std::printf("t,push,theta_ankle,theta_hip,foot_pitch,foot_roll,zmp_x,zmp_y,com_x,com_y,com_z,fz,f_toe,f_heel,"
              "contact_mode,sink,energy,fallen\n");
  auto row = [&](double t, double f) {
    const Outputs& o = plant.outputs();
    std::printf("%.6f,%.6g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%.10g,%d,%.6g,%.10g,%d\n",
                t, f, o.theta_ankle, o.theta_hip, o.foot_pitch, o.foot_roll, o.zmp_x, o.zmp_y, o.com_x, o.com_y,
                o.com_z, o.fz, o.f_toe, o.f_heel, o.contact_mode, plant.sink_depth(), o.energy, o.fallen ? 1 : 0);
  };
  row(0, 0);
  const long n = std::lround(duration / h);
  for (long k = 0; k < n; ++k) {
    const double t = k * h;
    const bool on = t >= t0 && t < t1;
    const double f = on ? (ramp > 0 ? ramp * (t - std::max(t0, 0.0)) : push) : 0.0;
    in.push_x = f;
    in.push_y = on ? push_y : 0.0;
    plant.set_inputs(in);
    const auto r = plant.do_step(h);
    row((k + 1) * h, f);
    if (r == Plant3D::Result::Fallen) {
      std::fprintf(stderr, "%s\n", plant.message().c_str());
      return 0;
    }
    if (r == Plant3D::Result::Error) {
      std::fprintf(stderr, "plant3d_tool: %s\n", plant.message().c_str());
      return 1;
    }
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc >= 2 && std::strcmp(argv[1], "describe") == 0) return describe();
  if (argc >= 2 && std::strcmp(argv[1], "run") == 0) return run(argc - 2, argv + 2);
  std::fprintf(stderr, "usage: plant3d_tool describe | run [--duration T] [--h H] [--push F] [--push-y F] "
                       "[--push-from T0] [--push-to T1] [--ramp R] [--set NAME=V ...]\n");
  return 2;
}
