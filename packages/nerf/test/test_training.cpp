// End-to-end checks on a tiny procedural scene: training improves held-out PSNR, training is
// deterministic, the trainer can be stopped and fed from other threads, model files round-trip
// and damaged files are refused.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "demnerf/core/error.hpp"
#include "demnerf/nerf/background_trainer.hpp"
#include "demnerf/nerf/evaluate.hpp"
#include "demnerf/nerf/model_io.hpp"
#include "demnerf/nerf/renderer.hpp"
#include "demnerf/nerf/trainer.hpp"
#include "ball_view.hpp"

namespace demnerf::nerf {
namespace {

constexpr double kSphereRadius = 0.45;

/// A camera on a sphere of radius `distance` looking at the origin (optical frame).
core::Frame makeCamera(const Eigen::Vector3d& eye, int size) {
  core::Frame frame;
  frame.camera.width = frame.camera.height = size;
  frame.camera.fx = frame.camera.fy = size * 1.1;
  frame.camera.cx = frame.camera.cy = size / 2.0;
  const Eigen::Vector3d z = (-eye).normalized();
  Eigen::Vector3d up = std::fabs(z.z()) > 0.95 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d x = z.cross(up).normalized();
  const Eigen::Vector3d y = z.cross(x);
  frame.world_from_camera.linear() << x, y, z;
  frame.world_from_camera.translation() = eye;
  return frame;
}

/// Ray-cast RGBA image of a sphere whose colour varies smoothly with the surface normal.
void renderSphere(core::Frame& frame) {
  const int n = frame.camera.width;
  frame.rgba.create(n, n, CV_32FC4);
  frame.has_alpha = true;
  for (int v = 0; v < n; ++v) {
    for (int u = 0; u < n; ++u) {
      const Eigen::Vector3d d_cam((u + 0.5 - frame.camera.cx) / frame.camera.fx,
                                  (v + 0.5 - frame.camera.cy) / frame.camera.fy, 1.0);
      const Eigen::Vector3d d = (frame.world_from_camera.linear() * d_cam).normalized();
      const Eigen::Vector3d o = frame.world_from_camera.translation();
      const double b = o.dot(d), c = o.squaredNorm() - kSphereRadius * kSphereRadius;
      const double disc = b * b - c;
      cv::Vec4f pixel(0, 0, 0, 0);
      if (disc > 0) {
        const Eigen::Vector3d normal = (o + (-b - std::sqrt(disc)) * d).normalized();
        pixel = cv::Vec4f(0.5f + 0.4f * static_cast<float>(normal.x()), 0.5f + 0.4f * static_cast<float>(normal.y()),
                          0.3f + 0.3f * static_cast<float>(normal.z()), 1.0f);
      }
      frame.rgba.at<cv::Vec4f>(v, u) = pixel;
    }
  }
}

std::vector<core::Frame> sphereViews(int count, int size, double phase) {
  std::vector<core::Frame> frames;
  for (int i = 0; i < count; ++i) {
    // Fibonacci-like spread over the sphere of directions.
    const double z = 1.0 - 2.0 * (i + 0.5) / count;
    const double angle = i * 2.399963 + phase;
    const double r = std::sqrt(1.0 - z * z);
    frames.push_back(makeCamera(2.0 * Eigen::Vector3d(r * std::cos(angle), r * std::sin(angle), z), size));
    renderSphere(frames.back());
  }
  return frames;
}

NerfConfig tinyConfig() {
  NerfConfig c = test::smallBallConfig();  // 32-wide MLPs, FieldConfig's defaults
  c.train.target_samples = 1 << 14;
  return c;
}

Box tinyBox() {
  Box b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = -0.6f;
    b.max[a] = 0.6f;
  }
  return b;
}

class TinyScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    train_ = new std::vector<core::Frame>(sphereViews(32, 40, 0.0));
    test_ = new std::vector<core::Frame>(sphereViews(4, 40, 1.0));
  }
  static void TearDownTestSuite() {
    delete train_;
    delete test_;
  }
  static std::vector<core::Frame>* train_;
  static std::vector<core::Frame>* test_;
};
std::vector<core::Frame>* TinyScene::train_ = nullptr;
std::vector<core::Frame>* TinyScene::test_ = nullptr;

TEST_F(TinyScene, TrainingBeatsAnUntrainedModel) {
  Trainer trainer(tinyConfig(), tinyBox(), 1.0);
  trainer.addFrames(*train_);
  const double untrained = evaluate(trainer.model(), *test_, false).psnr;
  const TrainProgress p = trainer.train({20.0, 300}, {}, false);
  const Evaluation trained = evaluate(trainer.model(), *test_, true);
  std::printf("tiny sphere: untrained %.2f dB, trained %.2f dB (SSIM %.3f) after %lld iterations, %.1f s\n", untrained,
              trained.psnr, trained.ssim, static_cast<long long>(p.iteration), p.seconds);
  EXPECT_GT(trained.psnr, untrained + 8.0);
  EXPECT_GT(trained.psnr, 22.0);
  EXPECT_GT(p.psnr, 20.0);  // the training-batch PSNR the progress reports
}

TEST_F(TinyScene, SameSeedAndThreadsGiveTheSameWeights) {
  auto run = [&] {
    Trainer trainer(tinyConfig(), tinyBox(), 1.0);
    trainer.addFrames(*train_);
    trainer.step(20);  // crosses an occupancy update
    return trainer.model().ngp().table();
  };
  EXPECT_EQ(run(), run());
}

// Rays go to the workers in blocks as each comes free, and the gradients are summed in block
// order: one worker and two must train to the same bits.
TEST_F(TinyScene, OneAndTwoThreadsGiveTheSameWeights) {
  auto run = [&](int threads) {
    NerfConfig config = tinyConfig();
    config.train.threads = threads;
    Trainer trainer(config, tinyBox(), 1.0);
    trainer.addFrames(*train_);
    trainer.step(20);
    return trainer.model().ngp().table();
  };
  const std::vector<float> one = run(1), two = run(2);
  EXPECT_EQ(one, two);
  float largest = 0.0f;  // the weights moved: the comparison is not between two untrained tables
  for (float v : one) largest = std::max(largest, std::fabs(v));
  EXPECT_GT(largest, 1e-3f);
}

// The forward reads a half-precision copy of the table that Adam refreshes entry by entry; after
// training it must equal the float master rounded afresh, or the forward sees stale weights.
TEST_F(TinyScene, TrainingKeepsTheHalfTableCurrent) {
  if (!halfTableSupported()) GTEST_SKIP() << "this build has no half-precision forward";
  Trainer trainer(tinyConfig(), tinyBox(), 1.0);
  trainer.addFrames(*train_);
  trainer.step(20);
  NgpField& field = trainer.model().ngp();
  ASSERT_NE(field.halfTable(), nullptr);
  const std::vector<std::uint16_t> kept(field.halfTable(), field.halfTable() + field.table().size());
  std::vector<std::uint16_t> fresh(field.table().size());
  toHalf(field.table().data(), 0, static_cast<std::int64_t>(fresh.size()), fresh.data());
  EXPECT_EQ(kept, fresh);
}

// Issue 14: a live rig adds frames forever; the store keeps max_frames, evicting the most
// redundant viewpoint (the older of the closest pair), so distinct views survive.
TEST_F(TinyScene, FrameStoreHonoursMaxFramesByRedundancy) {
  Trainer trainer(tinyConfig(), tinyBox(), 1.0);
  trainer.setMaxFrames(6);
  std::vector<core::Frame> views(train_->begin(), train_->begin() + 6);
  trainer.addFrames(views);
  EXPECT_EQ(trainer.frameCount(), 6u);
  for (int k = 0; k < 20; ++k) {  // the same view again and again, as a camera at rest sends it
    core::Frame again = views[2];
    again.world_from_camera.translation() += Eigen::Vector3d(1e-4 * k, 0, 0);
    trainer.addFrame(again);
    ASSERT_EQ(trainer.frameCount(), 6u);
  }
  trainer.step(2);  // sampling still sees consistent pixel offsets after evictions
  trainer.setMaxFrames(3);
  EXPECT_EQ(trainer.frameCount(), 3u);
  trainer.step(1);
}

TEST_F(TinyScene, StopsOnRequestAndTakesFramesWhileTraining) {
  Trainer trainer(tinyConfig(), tinyBox(), 1.0);
  trainer.addFrames(std::vector<core::Frame>(train_->begin(), train_->begin() + 8));
  std::vector<TrainProgress> reports;
  std::mutex reports_mutex;
  std::thread worker([&] {
    trainer.train({}, [&](const TrainProgress& p) {
      std::lock_guard<std::mutex> lock(reports_mutex);
      reports.push_back(p);
    }, false, 0.2);
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  trainer.addFrames(std::vector<core::Frame>(train_->begin() + 8, train_->end()));
  const NerfModel copy = trainer.snapshot();  // safe while training
  std::this_thread::sleep_for(std::chrono::milliseconds(600));
  const auto asked = std::chrono::steady_clock::now();
  trainer.requestStop();
  worker.join();
  const double stop_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - asked).count();
  EXPECT_LT(stop_seconds, 2.0);
  EXPECT_GT(trainer.iteration(), 0);
  EXPECT_EQ(trainer.frameCount(), train_->size());
  std::lock_guard<std::mutex> lock(reports_mutex);
  ASSERT_GE(reports.size(), 2u);
  EXPECT_EQ(reports.back().frames, train_->size());
  EXPECT_GT(reports.back().rays_per_second, 0.0);
  EXPECT_EQ(copy.ngp().table().size(), trainer.model().ngp().table().size());
}

TEST_F(TinyScene, BackgroundTrainerAutosavesAndATrainerResumesFromTheFile) {
  const std::string path = (std::filesystem::temp_directory_path() / "demnerf_background.nerf").string();
  std::filesystem::remove(path);
  auto trainer = std::make_unique<Trainer>(tinyConfig(), tinyBox(), 1.0);
  trainer->addFrames(*train_);
  BackgroundTrainerConfig config;
  config.stop.iterations = 150;
  config.autosave_seconds = 0.5;
  config.model_path = path;
  config.earlier = {1000, 5.0, 0.0};  // as if resumed from a model trained 1000 steps for 5 s
  std::atomic<int> progress_reports{0};
  std::atomic<bool> done{false};
  std::atomic<std::int64_t> final_iteration{0};
  std::string error;
  BackgroundTrainerCallbacks callbacks;
  callbacks.progress = [&](const TrainProgress&) { ++progress_reports; };
  callbacks.done = [&](const NerfModel&, const TrainProgress& p) {
    final_iteration = p.iteration;
    done = p.iteration >= 150;
  };
  callbacks.error = [&](const std::string& message) { error = message; };
  {
    BackgroundTrainer background(std::move(trainer), config, callbacks);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (background.running() && std::chrono::steady_clock::now() < deadline) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    EXPECT_FALSE(background.running());
  }
  EXPECT_TRUE(done) << error;
  EXPECT_TRUE(error.empty()) << error;
  ASSERT_TRUE(std::filesystem::exists(path));
  // The final save's header continues the earlier training's count and time.
  const std::optional<TrainingRecord> record = readTrainingRecord(path);
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->iteration, 1000 + final_iteration.load());
  EXPECT_GT(record->seconds, 5.0);
  EXPECT_GT(record->psnr, 10.0);
  Trainer resumed(loadModel(path));
  resumed.addFrames(*train_);
  const double before = evaluate(resumed.model(), *test_, false).psnr;
  EXPECT_GT(before, 18.0);  // the saved weights, not a fresh model
  resumed.step(30);
  EXPECT_GT(evaluate(resumed.model(), *test_, false).psnr, before - 1.0);
}

TEST_F(TinyScene, ModelFileRoundTripRendersIdentically) {
  Trainer trainer(tinyConfig(), tinyBox(), 1.0);
  trainer.addFrames(*train_);
  trainer.step(30);
  const std::string path = (std::filesystem::temp_directory_path() / "demnerf_test_model.nerf").string();
  saveModel(trainer.model(), path);
  const NerfModel loaded = loadModel(path);
  EXPECT_FALSE(readTrainingRecord(path).has_value()) << "saved without a training record";
  saveModel(trainer.model(), path, TrainingRecord{30, 1.5, 20.0});
  const std::optional<TrainingRecord> record = readTrainingRecord(path);
  ASSERT_TRUE(record.has_value());
  EXPECT_EQ(record->iteration, 30);
  EXPECT_EQ(record->seconds, 1.5);
  EXPECT_EQ(record->psnr, 20.0);
  EXPECT_NO_THROW(loadModel(path)) << "a header with a record still loads";
  const core::Frame& view = test_->front();
  const RenderedImage a = renderImage(trainer.model(), view.camera, view.world_from_camera);
  const RenderedImage b = renderImage(loaded, view.camera, view.world_from_camera);
  EXPECT_EQ(cv::norm(a.color, b.color, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.depth, b.depth, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(a.opacity, b.opacity, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(a.opacity, cv::NORM_INF), 0.5);  // the view shows the object
  const std::vector<float> density = loaded.densityGrid(16);
  EXPECT_EQ(density.size(), 16u * 16u * 16u);
  std::filesystem::remove(path);
}

std::string readAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}
void writeAll(const std::string& path, const std::string& data) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
}
void expectRefused(const std::string& path, const std::string& words) {
  try {
    loadModel(path);
    ADD_FAILURE() << "loading a damaged model file succeeded; expected an error containing '" << words << "'";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << "message should name the file: " << e.what();
  }
}

TEST(ModelFile, DamagedFilesAreRefusedWithAClearMessage) {
  NerfModel model(tinyConfig(), tinyBox(), 1.0);
  const std::string dir = std::filesystem::temp_directory_path().string();
  const std::string good = dir + "/demnerf_test_good.nerf", bad = dir + "/demnerf_test_bad.nerf";
  saveModel(model, good);
  const std::string bytes = readAll(good);
  ASSERT_GT(bytes.size(), 1000u);
  EXPECT_NO_THROW(loadModel(good));

  writeAll(bad, bytes.substr(0, bytes.size() / 2));
  expectRefused(bad, "truncated");
  std::string flipped = bytes;
  flipped[bytes.size() * 3 / 4] ^= 0x5a;
  writeAll(bad, flipped);
  expectRefused(bad, "checksum");
  writeAll(bad, "hello, this is not a model at all");
  expectRefused(bad, "not a dem_nerf");
  std::string version = bytes;
  version[8] = 99;  // the version field follows the 8 magic bytes
  writeAll(bad, version);
  expectRefused(bad, "version 99");
  writeAll(bad, "");
  expectRefused(bad, "not a dem_nerf");
  std::filesystem::remove(good);
  std::filesystem::remove(bad);
  EXPECT_THROW(loadModel(dir + "/demnerf_no_such_model.nerf"), core::Error);
}

TEST(ModelFile, SaveIntoMissingDirectoryFailsClearly) {
  NerfModel model(tinyConfig(), tinyBox(), 1.0);
  EXPECT_THROW(saveModel(model, "/nonexistent_dir_demnerf/model.nerf"), core::Error);
}

TEST(NerfConfig, YamlSetsValuesAndRejectsUnknownKeys) {
  const NerfConfig c = parseNerfConfig("hash: {levels: 8, log2_table_size: 14}\ntrain: {loss: huber, seed: 7}\n");
  EXPECT_EQ(c.hash.levels, 8);
  EXPECT_EQ(c.hash.log2_table_size, 14);
  EXPECT_EQ(c.train.loss, "huber");
  EXPECT_EQ(c.train.seed, 7u);
  try {
    parseNerfConfig("hash: {levles: 8}\n", "my.yaml");
    ADD_FAILURE() << "unknown key accepted";
  } catch (const core::Error& e) {
    EXPECT_NE(std::string(e.what()).find("hash.levles"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("my.yaml"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parseNerfConfig("train: {loss: l3}\n"), core::Error);
  EXPECT_THROW(parseNerfConfig("occupancy: {resolution: 60}\n"), core::Error);
  const NerfConfig back = nerfConfigFromJson(toJson(c));
  EXPECT_EQ(back.hash.levels, 8);
  EXPECT_EQ(back.train.loss, "huber");
}

}  // namespace
}  // namespace demnerf::nerf
