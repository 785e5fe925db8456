#include "server/remote/local_model.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "server/geometry/sphere_sweep.h"
#include "server/query/scene_queries.h"

namespace hapticd::remote {
namespace {

// The part of a mesh within radius of c_B, as a mesh of its own (the whole mesh when
// every triangle is in it, so that a closed mesh stays a solid; no triangles when none
// is there); nullopt when the patch would pass kMaxModelTriangles. buffer is sized on
// first use.
std::optional<scene::MeshSpec> CutMeshPatch(const geometry::MeshBvh& bvh, const Vector3& c_B, double radius,
                                            std::vector<geometry::PreparedTriangle>& buffer) {
  const geometry::TriangleMesh& mesh = bvh.mesh();
  buffer.resize(kMaxModelTriangles + 1);
  const int n = geometry::GatherMeshTriangles(bvh, geometry::Capsule{c_B, c_B, radius}, buffer);
  if (n > kMaxModelTriangles) return std::nullopt;
  scene::MeshSpec patch;
  patch.pin = scene::Representation::kMesh;
  if (n == static_cast<int>(mesh.nondegenerate_triangles().size())) {
    if (mesh.num_triangles() > kMaxModelTriangles) return std::nullopt;
    patch.vertices = mesh.vertices();
    patch.triangles.assign(mesh.triangles().begin(), mesh.triangles().end());
    return patch;
  }
  // in the mesh's order, so that the same ball cuts the same patch
  std::vector<int> kept(n);
  for (int i = 0; i < n; ++i) kept[i] = buffer[i].index;
  std::sort(kept.begin(), kept.end());
  std::unordered_map<int, int> vertex_of;
  for (int t : kept) {
    std::array<int, 3> triangle;
    for (int k = 0; k < 3; ++k) {
      const int v = mesh.triangles()[t][k];
      const auto [it, added] = vertex_of.try_emplace(v, static_cast<int>(patch.vertices.size()));
      if (added) patch.vertices.push_back(mesh.vertices()[v]);
      triangle[k] = it->second;
    }
    patch.triangles.push_back(triangle);
  }
  return patch;
}

}  // namespace

double ModelRadius(double max_velocity, double round_trip_s, double model_interval_s, double avatar_radius) {
  const double reach = max_velocity * (std::max(round_trip_s, 0.0) + std::max(model_interval_s, 0.0));
  return std::min(reach + avatar_radius + kModelMarginM, kMaxModelRadiusM);
}

LocalModel CutLocalModel(const scene::SceneSnapshot& scene, const Vector3& center_W, double radius,
                         uint64_t version, double t_s) {
  LocalModel model;
  model.version = version;
  model.t_s = t_s;
  model.center_W = center_W;
  model.radius = radius;
  model.settings = scene.settings();
  model.settings.ray_backend = scene::RayBackend::kNative;
  std::vector<geometry::PreparedTriangle> buffer;  // for the meshes' patches
  const geometry::Aabb ball{center_W - Vector3::Constant(radius), center_W + Vector3::Constant(radius)};
  for (int i : scene.ObjectsNear(ball)) {
    const scene::SceneObject& object = scene.object(i);
    if (static_cast<int>(model.objects.size()) == kMaxModelObjects) {
      ++model.left_out;
      continue;
    }
    scene::ObjectSpec spec;
    spec.name = object.name;
    spec.X_WB = object.X_WB;
    spec.material = object.material;
    spec.motion = object.motion;
    spec.v_WB = object.v_WB;
    spec.w_WB = object.w_WB;
    spec.ray_backend = scene::RayBackend::kNative;
    bool cut = true;    // false: no room for it
    bool empty = false; // nothing of it within the ball (a mesh patch, a plane below): nothing to send
    std::visit(
        [&](const auto& shape) {
          using T = std::decay_t<decltype(shape)>;
          if constexpr (std::is_same_v<T, scene::ConvexShape>) {
            spec.shape = scene::ConvexSpec{shape.hull->vertices};
          } else if constexpr (std::is_same_v<T, scene::MeshShape>) {
            std::optional<scene::MeshSpec> patch =
                CutMeshPatch(*shape.bvh, object.X_WB.ToBody(center_W), radius, buffer);
            if (!patch) {
              cut = false;
            } else {
              empty = patch->triangles.empty();
              spec.shape = std::move(*patch);
            }
          } else if constexpr (std::is_same_v<T, scene::PlaneShape>) {
            // unbounded, so always near in the broad phase: its solid (z <= 0 in B)
            // misses the ball when the centre is more than radius above it
            empty = object.X_WB.ToBody(center_W).z() > radius;
            spec.shape = shape;
          } else {
            spec.shape = shape;
          }
        },
        object.shape);
    if (!cut) {
      ++model.left_out;
      continue;
    }
    if (!empty) model.objects.push_back(std::move(spec));
  }
  return model;
}

LocalRenderer::LocalRenderer(const force::SessionSettings& settings, ModelMotion motion)
    : session_(settings), motion_(motion) {}
LocalRenderer::LocalRenderer(LocalRenderer&&) noexcept = default;
LocalRenderer::~LocalRenderer() = default;

void LocalRenderer::Reset(const Vector3& p_W) {
  session_.Reset(p_W);
  last_avatar_W_ = p_W;
  last_f_W_.setZero();
  blend_offset_W_.setZero();
  blend_left_s_ = 0;
}

std::unique_ptr<PreparedModel> LocalRenderer::Prepare(const LocalModel& model, double now_s) {
  auto prepared = std::make_unique<PreparedModel>();
  prepared->builder = scene::SceneBuilder(model.settings);
  for (const scene::ObjectSpec& spec : model.objects) prepared->builder.Add(spec);
  prepared->builder.AdvanceKinematic(std::max(now_s - model.t_s, 0.0));
  prepared->scene = prepared->builder.Build(model.version);
  prepared->t_s = std::max(now_s, model.t_s);
  prepared->moving = prepared->builder.HasMovingObjects();
  prepared->version = model.version;
  prepared->center_W = model.center_W;
  prepared->radius = model.radius;
  return prepared;
}

bool LocalRenderer::Adopt(std::unique_ptr<PreparedModel>& model) {
  if (!model || model->version <= version_) return false;
  // a model adopted twice before a tick: the one in between is never rendered
  std::unique_ptr<PreparedModel> skipped = std::move(previous_);
  previous_ = std::move(model_);
  model_ = std::move(model);
  version_ = model_->version;
  if (skipped) model = std::move(skipped);  // back to the caller, to free
  return true;
}

bool LocalRenderer::Accept(const LocalModel& model, double now_s) {
  if (model.version <= version_) return false;
  std::unique_ptr<PreparedModel> prepared = Prepare(model, now_s);
  return Adopt(prepared);
}

bool LocalRenderer::Move(std::shared_ptr<const scene::SceneSnapshot>& scene, double t_s) {
  if (!model_ || !scene || scene->version() != version_) return false;
  model_->scene.swap(scene);
  model_->t_s = t_s;
  return true;
}

bool LocalRenderer::Covers(const Vector3& p_W) const {
  return model_ && (p_W - model_->center_W).norm() + session_.settings().avatar.radius <= model_->radius;
}

namespace {

// Whether two models hold the same surface about the avatar of radius r at p_W: the
// same deepest contact (depth and normal) within reach.
bool SameSurfaceNear(const scene::SceneSnapshot& a, const scene::SceneSnapshot& b, const Vector3& p_W, double r) {
  constexpr double kReach = 0.01;
  constexpr double kTolerance = 1e-9;
  const query::SceneContact ca = query::FindDeepestContact(a, p_W, r, kReach);
  const query::SceneContact cb = query::FindDeepestContact(b, p_W, r, kReach);
  if ((ca.object < 0) != (cb.object < 0)) return false;
  if (ca.object < 0) return true;
  return std::abs(ca.depth - cb.depth) <= kTolerance && (ca.normal_W - cb.normal_W).norm() <= kTolerance;
}

}  // namespace

force::TickOutput LocalRenderer::Tick(const force::DeviceInput& input, double dt) {
  static const scene::SceneSnapshot kFreeSpace(std::vector<scene::SceneObject>{}, scene::SceneSettings{}, 0);
  const scene::SceneSnapshot& scene = model_ ? *model_->scene : kFreeSpace;
  force::TickOutput output = session_.Tick(scene, input, dt);
  // admittance: the pose follows the avatar's dynamics, which smooth it already
  if (previous_ && session_.settings().device.mode == force::DeviceMode::kImpedance) {
    // the first tick on a new model: blend where it disagrees with the old one
    if (!SameSurfaceNear(*previous_->scene, scene, last_avatar_W_, session_.settings().avatar.radius)) {
      blend_offset_W_ = last_f_W_ - output.f_W;
      blend_left_s_ = kModelBlendS;
      ++blends_;
    }
  }
  if (previous_) retired_ = std::move(previous_);
  if (blend_left_s_ > 0) {
    output.f_W += blend_offset_W_ * (blend_left_s_ / kModelBlendS);
    blend_left_s_ -= dt;
  }
  last_avatar_W_ = output.avatar_W;
  last_f_W_ = output.f_W;
  if (motion_ == ModelMotion::kByTick && model_ && model_->moving) {
    model_->builder.AdvanceKinematic(dt);
    model_->scene = model_->builder.Build(version_);
    model_->t_s += dt;
  }
  return output;
}

void KinematicMotion::Follow(const PreparedModel& prepared) {
  builder_ = prepared.builder;
  version_ = prepared.version;
  t_s_ = prepared.t_s;
  moving_ = prepared.moving;
}

std::shared_ptr<const scene::SceneSnapshot> KinematicMotion::SceneAt(double t_s) {
  if (version_ == 0) return nullptr;
  // never back: a time before the last moves nothing
  if (t_s > t_s_) {
    builder_.AdvanceKinematic(t_s - t_s_);
    t_s_ = t_s;
  }
  return builder_.Build(version_);
}

}  // namespace hapticd::remote
