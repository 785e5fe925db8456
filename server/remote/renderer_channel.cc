#include "server/remote/renderer_channel.h"

#include <cmath>
#include <limits>

namespace hapticd::remote {
namespace {

// keepalive_s in ns; infinite (or beyond what int64 holds): none.
int64_t KeepaliveNs(double keepalive_s) {
  if (!(keepalive_s * 1e9 < 9e18)) return std::numeric_limits<int64_t>::max();
  return std::llround(keepalive_s * 1e9);
}

double NsToSeconds(int64_t ns) { return static_cast<double>(ns) * 1e-9; }

}  // namespace

RendererChannel::RendererChannel(bool tdpa, const DeadbandSettings& deadband, bool local_model)
    : end_(tdpa && !local_model, !local_model),
      deadband_(deadband),
      keepalive_ns_(KeepaliveNs(deadband.keepalive_s)) {}

void RendererChannel::Reset(const Vector3& start_W) {
  end_.Reset(start_W);
  target_W_ = start_W;
  state_any_ = false;
  state_p_W_ = start_W;
  state_v_W_.setZero();
  state_ns_ = 0;
  command_sent_ = false;
  f_sent_W_.setZero();
  command_sent_ns_ = 0;
}

void RendererChannel::ReceiveState(int64_t now_ns, const Vector3& p_W, const Vector3& v_W, double other_in) {
  end_.ReceiveOtherIn(other_in);
  state_any_ = true;
  state_p_W_ = p_W;
  state_v_W_ = v_W;
  state_ns_ = now_ns;
}

bool RendererChannel::Predicts(int64_t now_ns, int64_t period_ns) const {
  // (written so that a keep-alive of INT64_MAX does not overflow)
  return deadband_.on() && state_any_ && now_ns - state_ns_ - period_ns <= keepalive_ns_;
}

Vector3 RendererChannel::Predict(int64_t now_ns) const {
  return state_p_W_ + state_v_W_ * NsToSeconds(now_ns - state_ns_);
}

Vector3 RendererChannel::StepInput(const scene::SceneSnapshot& scene, const Vector3& target_W, double r, double dt,
                                   force::DeviceInput& input) {
  target_W_ = target_W;
  if (!target_W.allFinite()) {
    input.p_WD = target_W;
    return Vector3::Zero();
  }
  const Vector3 step = end_.Step(scene, target_W, r, dt);
  if (tdpa()) input.v_WD = step / dt;
  input.p_WD = end_.input_W();
  return step;
}

void RendererChannel::ObserveTick(const force::TickOutput& output, Vector3 step, bool refused) {
  if (refused) {
    end_.Retract(step);
    step.setZero();
  }
  end_.Observe(output, step);
}

bool RendererChannel::ForceOutOfBand(const Vector3& f_W) const {
  return ExceedsDeadband(f_W, f_sent_W_, deadband_.weber, deadband_.force_floor_n);
}

bool RendererChannel::AnswerDue(int64_t now_ns, bool out_of_band) const {
  return !command_sent_ || now_ns - command_sent_ns_ >= keepalive_ns_ || out_of_band;
}

void RendererChannel::RecordCommand(const Vector3& f_W, int64_t now_ns) {
  command_sent_ = true;
  f_sent_W_ = f_W;
  command_sent_ns_ = now_ns;
}

}  // namespace hapticd::remote
