#include "clients/cpp/local_model_device.h"

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
  version = std::max(version, other.version);
  return *this;
}

LocalModelDevice::LocalModelDevice(const force::SessionSettings& settings, const Vector3& start_W,
                                   int64_t session_start_ns)
    : renderer_(settings), session_start_ns_(session_start_ns), avatar_W_(start_W), inbox_(net::kMaxModelBytes) {
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
  // retired one to give back
  if (handover_pending_) HandOver();
  if (std::unique_lock lock(mutex_, std::try_to_lock); lock.owns_lock()) {
    if (ready_ && renderer_.Adopt(ready_)) ++counters_.adopted;
    if (!retiring_) retiring_ = renderer_.TakeRetired();
    const bool give_back = (retiring_ || ready_) && retired_.size() < retired_.capacity();
    if (give_back) retired_.push_back(retiring_ ? std::move(retiring_) : std::move(ready_));
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
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || inbox_size_ != 0 || !retired_.empty(); });
    if (stop_) return;
    freeing.swap(retired_);
    const std::size_t size = inbox_size_;
    if (size != 0) std::memcpy(bytes.data(), inbox_.data(), size);
    inbox_size_ = 0;
    lock.unlock();
    freeing.clear();
    std::unique_ptr<remote::PreparedModel> prepared;
    bool rejected = false;
    if (size != 0) {
      try {
        const remote::LocalModel model = net::DecodeLocalModel({bytes.data(), size});
        const double now_s = static_cast<double>(MonotonicNowNs() - session_start_ns_) * 1e-9;
        prepared = remote::LocalRenderer::Prepare(model, now_s);
      } catch (const std::exception&) {
        rejected = true;  // the model the device renders from stays
      }
    }
    lock.lock();
    if (rejected) ++rejected_;
    // a newer model than one still waiting replaces it (the older is freed here)
    if (prepared && (!ready_ || ready_->version < prepared->version)) ready_.swap(prepared);
    if (prepared) {
      lock.unlock();
      prepared.reset();
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
