// The only file that includes PCL (compile time): RANSAC with PCL's
// perpendicular-plane model, which rejects candidate planes tilted more than
// the allowed angle from the expected floor normal, so walls never win.
#include "ground/sac_plane.h"

#include <pcl/console/print.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

namespace calib {

std::optional<SacPlane> FindPlaneSac(const float* xyz, size_t count, const Eigen::Vector3d& axis,
                                     double max_angle_rad, double threshold_m,
                                     int max_iterations) {
  if (count < 3) return std::nullopt;
  // A failed consensus is a value here (the caller words the problem), not a line on stderr.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud(new pcl::PointCloud<pcl::PointXYZ>);
  cloud->resize(count);
  for (size_t i = 0; i < count; ++i) {
    (*cloud)[i].x = xyz[3 * i];
    (*cloud)[i].y = xyz[3 * i + 1];
    (*cloud)[i].z = xyz[3 * i + 2];
  }
  using Model = pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>;
  Model::Ptr model(new Model(cloud, false /* fixed seed */));
  model->setAxis(axis.cast<float>());
  model->setEpsAngle(max_angle_rad);
  pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, threshold_m);  // fixed seed by default
  ransac.setMaxIterations(max_iterations);
  ransac.setNumberOfThreads(-1);  // serial: one core, and the same result every run
  ransac.setProbability(0.999);
  if (!ransac.computeModel()) return std::nullopt;
  Eigen::VectorXf coefficients;
  ransac.getModelCoefficients(coefficients);
  if (coefficients.size() != 4) return std::nullopt;
  std::vector<int> inliers;
  ransac.getInliers(inliers);
  SacPlane plane;
  plane.normal = coefficients.head<3>().cast<double>();
  const double norm = plane.normal.norm();
  if (!(norm > 0)) return std::nullopt;
  plane.d = coefficients[3] / norm;
  plane.normal /= norm;
  if (plane.normal.dot(axis) < 0) {
    plane.normal = -plane.normal;
    plane.d = -plane.d;
  }
  plane.inliers = static_cast<int>(inliers.size());
  return plane;
}

}  // namespace calib
