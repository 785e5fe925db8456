#include "clients/cpp/local_model_device.h"

#include <chrono>
#include <cmath>
#include <cstring>

#include "clients/cpp/tick_schedule.h"

namespace hapticd::proxy {
namespace {

// Retired models waiting for the builder to free them: a handful at most (one per
// adoption, and the builder frees them as soon as it runs).
constexpr std::size_t kRetiredCapacity = 8;

}  // namespace

LocalModelCounters& LocalModelCounters::operator+=(const LocalModelCounters& other) {
  fragments += other.fragments;
  completed += other.completed;
  adopted += other.adopted;
  rejected += other.rejected;
  blends += other.blends;
  moved += other.moved;
  version = std::max(version, other.version);
  return *this;
}

LocalModelDevice::LocalModelDevice(const force::SessionSettings& settings, const Vector3& start_W,
                                   int64_t session_start_ns)
    : renderer_(settings, remote::ModelMotion::kByCaller),
      session_start_ns_(session_start_ns),
      motion_period_ns_(std::max<int64_t>(std::llround(1e9 / settings.device.rate_hz), 1)),
      avatar_W_(start_W),
      inbox_(net::kMaxModelBytes) {
  renderer_.Reset(start_W);
  retired_.reserve(kRetiredCapacity);
  builder_ = std::thread([this] { Build(); });
}

LocalModelDevice::~LocalModelDevice() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  builder_.join();
}

void LocalModelDevice::Offer(const net::ModelFragmentView& fragment) {
  ++counters_.fragments;
  if (!assembler_.Offer(fragment)) return;
  ++counters_.completed;
  handover_pending_ = true;
  HandOver();
}

bool LocalModelDevice::HandOver() {
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock()) return false;
  const std::span<const uint8_t> bytes = assembler_.bytes();
  std::memcpy(inbox_.data(), bytes.data(), bytes.size());
  inbox_size_ = bytes.size();
  handover_pending_ = false;
  lock.unlock();
  wake_.notify_one();
  return true;
}

force::TickOutput LocalModelDevice::Tick(const DeviceReading& reading, const Vector3& f_held_W, double dt) {
  // what waits for the lock: a completed model to hand over, a ready one to take, a
  // moved scene to swap in, a retired model or scene to give back
  if (handover_pending_) HandOver();
  if (std::unique_lock lock(mutex_, std::try_to_lock); lock.owns_lock()) {
    if (ready_ && renderer_.Adopt(ready_)) ++counters_.adopted;
    if (!retiring_) retiring_ = renderer_.TakeRetired();
    const bool give_back = (retiring_ || ready_) && retired_.size() < retired_.capacity();
    if (give_back) retired_.push_back(retiring_ ? std::move(retiring_) : std::move(ready_));
    // the scene it replaces takes the moved one's place on the way back (one of another
    // version stays for the builder to replace); the builder frees it when it wakes for
    // the next, so nobody is woken for it
    if (moved_.scene && !moved_back_ && renderer_.Move(moved_.scene, moved_.t_s)) {
      moved_back_.swap(moved_.scene);
      ++counters_.moved;
    }
    lock.unlock();
    if (give_back) wake_.notify_one();
  }
  force::DeviceInput input;
  input.p_WD = reading.p_W;
  input.v_WD = reading.v_W;
  input.f_held_W = f_held_W;
  const force::TickOutput output = renderer_.Tick(input, dt);
  avatar_W_ = output.avatar_W;
  counters_.blends = static_cast<uint64_t>(renderer_.blends());
  counters_.version = renderer_.model_version();
  return output;
}

void LocalModelDevice::Build() {
  std::vector<uint8_t> bytes(net::kMaxModelBytes);
  std::vector<std::unique_ptr<remote::PreparedModel>> freeing;
  freeing.reserve(kRetiredCapacity);
  std::shared_ptr<const scene::SceneSnapshot> freeing_scene;
  remote::KinematicMotion motion;  // the newest model's, moved on every period while it moves
  int64_t next_move_ns = 0;        // when the next moved scene is due
  const auto session_s = [this](int64_t ns) { return static_cast<double>(ns - session_start_ns_) * 1e-9; };
  std::unique_lock lock(mutex_);
  for (;;) {
    const auto work = [this] { return stop_ || inbox_size_ != 0 || !retired_.empty() || moved_back_; };
    if (motion.moving()) {
      const auto wait = std::chrono::nanoseconds(next_move_ns - MonotonicNowNs());
      wake_.wait_until(lock, std::chrono::steady_clock::now() + wait, work);
    } else {
      wake_.wait(lock, work);
    }
    if (stop_) return;
    freeing.swap(retired_);
    freeing_scene.swap(moved_back_);
    const std::size_t size = inbox_size_;
    if (size != 0) std::memcpy(bytes.data(), inbox_.data(), size);
    inbox_size_ = 0;
    lock.unlock();
    freeing.clear();
    freeing_scene.reset();
    std::unique_ptr<remote::PreparedModel> prepared;
    bool rejected = false;
    if (size != 0) {
      try {
        const remote::LocalModel model = net::DecodeLocalModel({bytes.data(), size});
        prepared = remote::LocalRenderer::Prepare(model, session_s(MonotonicNowNs()));
      } catch (const std::exception&) {
        rejected = true;  // the model the device renders from stays
      }
    }
    // the newest model is the one the loop will render: its objects move on from here
    if (prepared && prepared->version > motion.version()) {
      motion.Follow(*prepared);
      next_move_ns = MonotonicNowNs() + motion_period_ns_;
    }
    // due: the scene for half a period ahead (the next due one a period on, or, after a
    // stall, a period from now: the ones missed would help no tick)
    MovedScene moved;
    if (const int64_t now_ns = MonotonicNowNs(); motion.moving() && now_ns >= next_move_ns) {
      moved.t_s = session_s(now_ns + motion_period_ns_ / 2);
      moved.scene = motion.SceneAt(moved.t_s);
      next_move_ns += motion_period_ns_;
      if (next_move_ns <= now_ns) next_move_ns = now_ns + motion_period_ns_;
    }
    lock.lock();
    if (rejected) ++rejected_;
    // a newer model than one still waiting replaces it (the older is freed here)
    if (prepared && (!ready_ || ready_->version < prepared->version)) ready_.swap(prepared);
    // a newer moved scene replaces one not yet swapped in, and a model followed since
    // makes one of the model before stale (either is freed here)
    if (moved.scene || (moved_.scene && moved_.scene->version() != motion.version())) {
      std::swap(moved, moved_);
    }
    if (prepared || moved.scene) {
      lock.unlock();
      prepared.reset();
      moved.scene.reset();
      lock.lock();
    }
  }
}

LocalModelCounters LocalModelDevice::counters() {
  LocalModelCounters counters = counters_;
  std::lock_guard lock(mutex_);
  counters.rejected = rejected_;
  return counters;
}

}  // namespace hapticd::proxy
