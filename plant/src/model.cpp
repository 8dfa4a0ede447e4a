// HOAP-2 sagittal model: closed-form kinematics of a 3-body planar chain on a floating foot,
// M(q) = sum_i m_i Jv_i^T Jv_i + I_i s_i s_i^T, h = sum_i m_i Jv_i^T (Jdot_i qd + g e_z),
// and the constrained dynamics of the contact modes (see model.hpp for the coordinates).
#include "hoap2plant/model.hpp"

#include <algorithm>

#include <Eigen/Eigenvalues>

#include <cmath>

#include "hoap2/servo.h"

namespace hoap2plant {

namespace {
// Body-frame offset (cx, cz) rotated by absolute pitch a.
inline Vec2 rot(double a, double cx, double cz) {
  const double c = std::cos(a), s = std::sin(a);
  return Vec2(cx * c + cz * s, -cx * s + cz * c);
}
// d/da of rot(a, ...) = (r_z, -r_x).
inline Vec2 drot(const Vec2& r) { return Vec2(r.y(), -r.x()); }
}  // namespace

Vec2 Model::foot_point(const Vec5& q, double cx, double cz) const {
  return Vec2(q[0], q[1]) + rot(q[2], cx, cz);
}

void Model::foot_point_jac(const Vec5& q, const Vec5& qd, double cx, double cz,
                           Eigen::Matrix<double, 2, 5>& J, Vec2& bias) const {
  const Vec2 r = rot(q[2], cx, cz);
  J.setZero();
  J(0, 0) = 1.0;
  J(1, 1) = 1.0;
  J.col(2) = drot(r);
  bias = -r * qd[2] * qd[2];
}

void Model::push_point(const Vec5& q, const Vec5& qd, Vec2& pos, Eigen::Matrix<double, 2, 5>& J,
                       Vec2& bias) const {
  const double a1 = q[2] + q[3], a2 = a1 + q[4];
  const double w1 = qd[2] + qd[3], w2 = w1 + qd[4];
  const double d = P.h_push - P.ankle_height - P.l1;  // along link 2 from the hip
  const Vec2 rh = rot(a1, 0.0, P.l1), rp = rot(a2, 0.0, d);
  pos = Vec2(q[0], q[1]) + rh + rp;
  J.setZero();
  J(0, 0) = 1.0;
  J(1, 1) = 1.0;
  J.col(2) = drot(rh) + drot(rp);
  J.col(3) = drot(rh) + drot(rp);
  J.col(4) = drot(rp);
  bias = -rh * w1 * w1 - rp * w2 * w2;
}

void Model::kinematics(const Vec5& q, const Vec5& qd, Kinematics& k) const {
  const Vec2 A(q[0], q[1]);
  const double a0 = q[2], a1 = q[2] + q[3], a2 = a1 + q[4];
  const double w0 = qd[2], w1 = qd[2] + qd[3], w2 = w1 + qd[4];
  const double c0 = std::cos(a0), s0 = std::sin(a0), c1 = std::cos(a1), s1 = std::sin(a1);
  const double c2 = std::cos(a2), s2 = std::sin(a2);  // one sine and cosine per absolute angle
  // foot CoM (relative to the ankle axis: forward feet_com_x, up feet_com_z - ankle_height)
  const double fx = P.feet_com_x, fz = P.feet_com_z - P.ankle_height;
  const Vec2 rf(fx * c0 + fz * s0, -fx * s0 + fz * c0);
  const Vec2 u1(s1, c1), u2(s2, c2);  // unit vectors along links 1 and 2 (rot(a, 0, 1))
  const Vec2 r1 = P.lg1 * u1, rh = P.l1 * u1, r2 = P.lg2 * u2;
  for (auto& J : k.J) {
    J.setZero();
    J(0, 0) = 1.0;
    J(1, 1) = 1.0;
  }
  k.p[0] = A + rf;
  k.J[0].col(2) = drot(rf);
  k.b[0] = -rf * w0 * w0;
  k.p[1] = A + r1;
  k.J[1].col(2) = drot(r1);
  k.J[1].col(3) = drot(r1);
  k.b[1] = -r1 * w1 * w1;
  k.p[2] = A + rh + r2;
  k.J[2].col(2) = drot(rh) + drot(r2);
  k.J[2].col(3) = drot(rh) + drot(r2);
  k.J[2].col(4) = drot(r2);
  k.b[2] = -rh * w1 * w1 - r2 * w2 * w2;
  const double S[3][5] = {{0, 0, 1, 0, 0}, {0, 0, 1, 1, 0}, {0, 0, 1, 1, 1}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 5; ++j) k.s[i][j] = S[i][j];
}

// M = sum_i m_i Jv_i^T Jv_i + I_i s_i s_i^T and h = sum_i m_i Jv_i^T (b_i + g e_z), written out
// for the structure of the chain: every Jv_i is [I_2 | c_i2 c_i3 c_i4] with 2-vector columns
// (zero where body i does not move with that angle) and s_i = (0, 0, 1, [1], [1]).
void Model::mass_bias(const Vec5& q, const Vec5& qd, Mat5& M, Vec5& h) const {
  Kinematics k;
  kinematics(q, qd, k);
  const double m[3] = {P.feet_mass, P.m1, P.m2};
  const double I[3] = {P.feet_inertia, P.I1, P.I2};
  const int last[3] = {2, 3, 4};  // body i moves with the angles 2 .. last[i]
  M.setZero();
  h.setZero();
  for (int i = 0; i < 3; ++i) {
    const Vec2 acc = k.b[i] + Vec2(0.0, P.g);
    M(0, 0) += m[i];
    M(1, 1) += m[i];
    h[0] += m[i] * acc.x();
    h[1] += m[i] * acc.y();
    for (int j = 2; j <= last[i]; ++j) {
      const Vec2 cj = k.J[i].col(j);
      M(0, j) += m[i] * cj.x();
      M(1, j) += m[i] * cj.y();
      h[j] += m[i] * cj.dot(acc);
      for (int l = 2; l <= j; ++l) M(l, j) += m[i] * cj.dot(k.J[i].col(l)) + I[i];
    }
  }
  for (int j = 0; j < 5; ++j)
    for (int l = j + 1; l < 5; ++l) M(l, j) = M(j, l);
}

Vec2 Model::com(const Vec5& q) const {
  const double a0 = q[2], a1 = q[2] + q[3], a2 = a1 + q[4];
  const double fx = P.feet_com_x, fz = P.feet_com_z - P.ankle_height;
  const double c0 = std::cos(a0), s0 = std::sin(a0), c1 = std::cos(a1), s1 = std::sin(a1);
  const double c2 = std::cos(a2), s2 = std::sin(a2);
  const Vec2 pf(fx * c0 + fz * s0, -fx * s0 + fz * c0);
  const Vec2 p1 = P.lg1 * Vec2(s1, c1), p2 = P.l1 * Vec2(s1, c1) + P.lg2 * Vec2(s2, c2);
  return Vec2(q[0], q[1]) + (P.feet_mass * pf + P.m1 * p1 + P.m2 * p2) / P.mass();
}

double Model::kinetic_energy(const Vec5& q, const Vec5& qd) const {
  Mat5 M;
  Vec5 h;
  mass_bias(q, qd, M, h);
  return 0.5 * qd.dot(M * qd);
}

double Model::potential_energy(const Vec5& q) const { return P.mass() * P.g * com(q).y(); }

void Model::joint_torques(const Vec5& q, const Vec5& qd, double ref1, double ref2, double& tau1,
                          double& tau2) const {
  auto servo = [](double e, double w, double kp, double kd, double vmax, double tmax) {
    if (kd > 0) {
      const double wcmd = hoap2_soft_sat(kp / kd * e, vmax);  // position loop -> velocity command
      return hoap2_soft_sat(kd * (wcmd - w), tmax);           // velocity loop -> torque (limited)
    }
    return hoap2_soft_sat(kp * e, tmax);
  };
  tau1 = -P.damping_ankle * qd[3];
  tau2 = -P.damping_hip * qd[4];
  if (P.servo_on) {
    tau1 += servo(ref1 - q[3], qd[3], P.kp_ankle, P.kd_ankle, P.vel_max_ankle, P.tau_max_ankle);
    tau2 += servo(ref2 - q[4], qd[4], P.kp_hip, P.kd_hip, P.vel_max_hip, P.tau_max_hip);
  }
}

Vec5 Model::applied(const Vec5& q, const Vec5& qd, double ref1, double ref2, double push) const {
  Vec5 Q = Vec5::Zero();
  joint_torques(q, qd, ref1, ref2, Q[3], Q[4]);
  if (push != 0.0) {
    Vec2 pos, bias;
    Eigen::Matrix<double, 2, 5> J;
    push_point(q, qd, pos, J, bias);
    Q.noalias() += J.transpose() * Vec2(push, 0.0);
  }
  return Q;
}

Model::Dyn Model::dynamics(ContactMode mode, const Vec5& q, const Vec5& qd, double ref1,
                           double ref2, double push, const Vec2& pivot) const {
  Mat5 M;
  Vec5 h;
  mass_bias(q, qd, M, h);
  const Vec5 Q = applied(q, qd, ref1, ref2, push);
  Dyn d;
  d.qdd.setZero();
  d.Qc.setZero();
  switch (mode) {
    case ContactMode::Flat: {
      // Foot fixed: qdd_foot = 0 exactly; joints from the reduced system; the constraint force
      // on (x, z, phi) is Qc_a = M_ab qdd_b + h_a - Q_a.
      const Eigen::Matrix2d Mbb = M.block<2, 2>(3, 3);
      const Eigen::Vector2d rhs = Q.tail<2>() - h.tail<2>();
      const Eigen::Vector2d qb = Mbb.ldlt().solve(rhs);
      d.qdd.tail<2>() = qb;
      d.Qc.head<3>() = M.block<3, 2>(0, 3) * qb + h.head<3>() - Q.head<3>();
      break;
    }
    case ContactMode::Toe:
    case ContactMode::Heel: {
      const double cx = mode == ContactMode::Toe ? P.toe_x : P.heel_x;
      Eigen::Matrix<double, 2, 5> J;
      Vec2 bias;
      foot_point_jac(q, qd, cx, -P.ankle_height, J, bias);
      const Vec2 c = foot_point(q, cx, -P.ankle_height) - pivot;
      const Vec2 cd = J * qd;
      const double a = P.baumgarte;
      const Vec2 stab = bias + 2.0 * a * cd + a * a * c;
      const Eigen::LDLT<Mat5> ldlt(M);
      const Vec5 qf = ldlt.solve(Q - h);
      const Eigen::Matrix<double, 5, 2> MiJt = ldlt.solve(J.transpose());
      const Eigen::Matrix2d A = J * MiJt;
      const Vec2 lambda = A.ldlt().solve(-stab - J * qf);
      d.qdd = qf + MiJt * lambda;
      d.Qc = J.transpose() * lambda;
      break;
    }
    case ContactMode::Airborne:
      d.qdd = M.ldlt().solve(Q - h);
      break;
  }
  return d;
}

Vec2 Model::flat_joint_accelerations(const Vec5& q, const Vec5& qd, double ref1, double ref2,
                                     double push) const {
  const double a1 = q[2] + q[3], a2 = a1 + q[4];
  const double w1 = qd[2] + qd[3], w2 = w1 + qd[4];
  const double s1 = std::sin(a1), c1 = std::cos(a1), s2 = std::sin(a2), c2 = std::cos(a2);
  // CoM offsets of link 1 and link 2 (and the hip) from the ankle; the columns of their CoM
  // Jacobians for theta1 and theta2 are drot(r) = (r_z, -r_x) (see kinematics()).
  const Vec2 r1(P.lg1 * s1, P.lg1 * c1), rh(P.l1 * s1, P.l1 * c1), r2(P.lg2 * s2, P.lg2 * c2);
  const Vec2 j1(r1.y(), -r1.x());                                // link 1, theta1
  const Vec2 j23(rh.y() + r2.y(), -rh.x() - r2.x()), j24(r2.y(), -r2.x());  // link 2, theta1 / theta2
  const Vec2 acc1 = -r1 * (w1 * w1) + Vec2(0.0, P.g);            // bias acceleration + gravity
  const Vec2 acc2 = -rh * (w1 * w1) - r2 * (w2 * w2) + Vec2(0.0, P.g);
  const double M33 = P.m1 * j1.dot(j1) + P.I1 + P.m2 * j23.dot(j23) + P.I2;
  const double M34 = P.m2 * j23.dot(j24) + P.I2;
  const double M44 = P.m2 * j24.dot(j24) + P.I2;
  double tau1 = 0, tau2 = 0;
  joint_torques(q, qd, ref1, ref2, tau1, tau2);
  double Q3 = tau1 - P.m1 * j1.dot(acc1) - P.m2 * j23.dot(acc2);
  double Q4 = tau2 - P.m2 * j24.dot(acc2);
  if (push != 0.0) {  // the push point's Jacobian, x row (push_point())
    const double d = P.h_push - P.ankle_height - P.l1;
    Q3 += push * (P.l1 * c1 + d * c2);
    Q4 += push * d * c2;
  }
  const double det = M33 * M44 - M34 * M34;  // M is positive definite
  return Vec2((M44 * Q3 - M34 * Q4) / det, (M33 * Q4 - M34 * Q3) / det);
}

Vec5 Model::impact(ContactMode mode, const Vec5& q, const Vec5& qd) const {
  if (mode == ContactMode::Airborne) return qd;
  Mat5 M;
  Vec5 h;
  mass_bias(q, qd, M, h);
  const Eigen::LDLT<Mat5> ldlt(M);
  const int nc = mode == ContactMode::Flat ? 3 : 2;      // contact rows
  const int nj = P.lock_joints_at_impact ? 2 : 0;       // joint rows (rates held)
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(nc + nj, 5);
  if (mode == ContactMode::Flat) {
    J.block<3, 3>(0, 0).setIdentity();
  } else {
    Eigen::Matrix<double, 2, 5> Jp;
    Vec2 bias;
    foot_point_jac(q, qd, mode == ContactMode::Toe ? P.toe_x : P.heel_x, -P.ankle_height, Jp,
                   bias);
    J.topRows<2>() = Jp;
  }
  if (nj) J.bottomRightCorner<2, 2>().setIdentity();
  // Plastic impact: qd+ = qd- + M^-1 J^T lambda with J_contact qd+ = 0 and (locked joints) the
  // joint rates unchanged: lambda = (J M^-1 J^T)^-1 (-J_contact qd-, 0) (momentum-consistent).
  const Eigen::MatrixXd MiJt = ldlt.solve(J.transpose());
  const Eigen::MatrixXd A = J * MiJt;
  Eigen::VectorXd rhs = Eigen::VectorXd::Zero(nc + nj);
  rhs.head(nc) = -(J.topRows(nc) * qd);
  Vec5 out = qd + MiJt * A.ldlt().solve(rhs);
  if (mode == ContactMode::Flat) out.head<3>().setZero();
  if (nj) out.tail<2>() = qd.tail<2>();
  return out;
}

double Model::fastest_rate(const Vec5& q) const {
  // Central differences of the right-hand side about rest (each mode's state: flat the two joints,
  // rocking all five coordinates), then the eigenvalues of that Jacobian.
  const double ref1 = q[3], ref2 = q[4], eps = 1e-7;
  double fastest = 0.0;
  {
    auto f = [&](const Eigen::Vector4d& x) {
      Vec5 qq = q, qd = Vec5::Zero();
      qq[3] = x[0]; qq[4] = x[1]; qd[3] = x[2]; qd[4] = x[3];
      const Vec2 a = flat_joint_accelerations(qq, qd, ref1, ref2, 0.0);
      return Eigen::Vector4d(x[2], x[3], a[0], a[1]);
    };
    const Eigen::Vector4d x0(q[3], q[4], 0.0, 0.0);
    Eigen::Matrix4d J;
    for (int i = 0; i < 4; ++i) {
      Eigen::Vector4d a = x0, b = x0;
      a[i] += eps;
      b[i] -= eps;
      J.col(i) = (f(a) - f(b)) / (2.0 * eps);
    }
    fastest = Eigen::EigenSolver<Eigen::Matrix4d>(J, false).eigenvalues().cwiseAbs().maxCoeff();
  }
  for (ContactMode mode : {ContactMode::Toe, ContactMode::Heel}) {
    const Vec2 pivot = foot_point(q, mode == ContactMode::Toe ? P.toe_x : P.heel_x, -P.ankle_height);
    using Vec10 = Eigen::Matrix<double, 10, 1>;
    using Mat10 = Eigen::Matrix<double, 10, 10>;
    auto f = [&](const Vec10& x) {
      const Vec5 qq = x.head<5>(), qd = x.tail<5>();
      Vec10 y;
      y.head<5>() = qd;
      y.tail<5>() = dynamics(mode, qq, qd, ref1, ref2, 0.0, pivot).qdd;
      return y;
    };
    Vec10 x0 = Vec10::Zero();
    x0.head<5>() = q;
    Mat10 J;
    for (int i = 0; i < 10; ++i) {
      Vec10 a = x0, b = x0;
      a[i] += eps;
      b[i] -= eps;
      J.col(i) = (f(a) - f(b)) / (2.0 * eps);
    }
    fastest = std::max(fastest, Eigen::EigenSolver<Mat10>(J, false).eigenvalues().cwiseAbs().maxCoeff());
  }
  return fastest;
}

}  // namespace hoap2plant
