#include "server/remote/channel_ends.h"

#include <algorithm>

#include "server/query/scene_queries.h"

namespace hapticd::remote {

void DeviceEnd::Reset(const Vector3& p_W) {
  port_.Reset();
  p_last_W_ = p_W;
  v_last_W_.setZero();
  v_mid_W_.setZero();
  v_surface_W_.setZero();
}

Vector3 DeviceEnd::Limit(const Vector3& f_W, double dt) {
  if (!local_model_) return port_.LimitForce(f_W, v_mid_W_, dt);
  // a one-port: what the hand put in is what may come out, less a reserve for the
  // ticks whose prediction falls short
  port_.ReceiveOtherIn(port_.energy().in - kLocalModelReserveJ);
  return port_.LimitForce(f_W, v_mid_W_ - v_surface_W_, dt);
}

void DeviceEnd::Sample(const Vector3& p_W, const Vector3& v_W, const Vector3& f_W, double held_s) {
  Vector3 moved = p_W - p_last_W_;
  if (local_model_) moved -= v_surface_W_ * held_s;
  port_.Observe(f_W.dot(moved));
  v_mid_W_ = v_W + 0.5 * (v_W - v_last_W_);
  p_last_W_ = p_W;
  v_last_W_ = v_W;
}

EnvironmentNear FindEnvironmentNear(const scene::SceneSnapshot& scene, const Vector3& f_env_W, int touched,
                                    const Vector3& avatar_W, const Vector3& p_input_W, double r,
                                    const Vector3& step, double dt) {
  EnvironmentNear near;
  near.f_W = f_env_W;
  // touching: the object the avatar touched last tick, moving at the proxy; else the
  // surface nearest the avatar input, which the step may reach (an index from an older
  // snapshot that this one does not have counts as not touching)
  int object = touched < scene.num_objects() ? touched : -1;
  Vector3 at_W = avatar_W;
  if (object < 0 || f_env_W.isZero()) {
    const double reach = step.norm() + 1e-3;
    const query::SceneContact contact = query::FindDeepestContact(scene, p_input_W, r, reach);
    object = contact.object;
    at_W = contact.point_W;
    near.normal_W = contact.normal_W;
    // inside already (a force the watchdog's ramp took away, a penalty input): the
    // spring pressed that deep
    near.gap = contact.object >= 0 ? -contact.depth : 0.0;
  } else {
    near.normal_W = f_env_W.normalized();
  }
  if (object >= 0) {
    const scene::SceneObject& surface = scene.object(object);
    near.stiffness = surface.material.stiffness;
    near.damping = surface.material.damping;
    // a kinematic surface coming towards the avatar
    near.approach = std::max(surface.CalcPointVelocity(at_W).dot(near.normal_W), 0.0) * dt;
  }
  return near;
}

void RendererEnd::Reset(const Vector3& start_W) {
  port_.Reset();
  input_W_ = start_W;
  f_env_W_.setZero();
  touched_ = -1;
  avatar_W_ = start_W;
}

Vector3 RendererEnd::Step(const scene::SceneSnapshot& scene, const Vector3& target_W, double r, double dt) {
  Vector3 step = target_W - input_W_;
  if (!port_.control()) {
    input_W_ = target_W;
    return step;
  }
  const EnvironmentNear near = FindEnvironmentNear(scene, f_env_W_, touched_, avatar_W_, input_W_, r, step, dt);
  step = port_.LimitStep(step, near, dt);
  input_W_ += step;
  return step;
}

void RendererEnd::Observe(const force::TickOutput& output, const Vector3& step) {
  if (observes_) port_.Observe(-output.f_W.dot(step));
  Remember(output);
}

void RendererEnd::Remember(const force::TickOutput& output) {
  // the force as the next fresh input renders it: before the watchdog's ramp
  f_env_W_ = output.f_unscaled_W;
  touched_ = output.touched_object;
  avatar_W_ = output.avatar_W;
}

}  // namespace hapticd::remote
