#include "conversions/marker_conversions.hpp"

#include <ros/time.h>

#include <algorithm>

namespace dem_nerf {
namespace {

visualization_msgs::Marker regionMarker(const demnerf::core::Region& region, const std::string& frame, int id,
                                        float r, float g, float b) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "fixtures";
  marker.id = id;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.position.x = region.center.x();
  marker.pose.position.y = region.center.y();
  marker.pose.position.z = region.center.z();
  marker.pose.orientation.w = 1.0;
  if (region.type == demnerf::core::Region::Type::kSphere) {
    marker.type = visualization_msgs::Marker::SPHERE;
    marker.scale.x = marker.scale.y = marker.scale.z = 2.0 * region.radius;
  } else {
    marker.type = visualization_msgs::Marker::CUBE;
    const Eigen::Vector3d size =
        region.type == demnerf::core::Region::Type::kBox ? region.size : Eigen::Vector3d::Constant(0.01);
    marker.scale.x = size.x();
    marker.scale.y = size.y();
    marker.scale.z = size.z();
  }
  marker.color.r = r;
  marker.color.g = g;
  marker.color.b = b;
  marker.color.a = 0.4f;
  return marker;
}

// Force arrows start at the load patch and are drawn 0.05 m long per newton of the largest load.
visualization_msgs::Marker forceArrow(const demnerf::core::Load& load, const std::string& frame, int id, double scale) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "loads";
  marker.id = id;
  marker.type = visualization_msgs::Marker::ARROW;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  geometry_msgs::Point tail, head;
  tail.x = load.region.center.x();
  tail.y = load.region.center.y();
  tail.z = load.region.center.z();
  const Eigen::Vector3d tip = load.region.center + scale * load.force;
  head.x = tip.x();
  head.y = tip.y();
  head.z = tip.z();
  marker.points = {tail, head};
  marker.scale.x = 0.005;
  marker.scale.y = 0.01;
  marker.scale.z = 0.015;
  marker.color.r = 1.0f;
  marker.color.g = 0.3f;
  marker.color.a = 1.0f;
  return marker;
}

}  // namespace

visualization_msgs::MarkerArray resultMarkers(const demnerf::core::Scenario& scenario, const std::string& frame) {
  visualization_msgs::MarkerArray markers;
  double largest = 0.0;
  for (const auto& load : scenario.loads) largest = std::max(largest, load.force.norm());
  int id = 0;
  for (const auto& fixture : scenario.fixtures) markers.markers.push_back(regionMarker(fixture.region, frame, id++, 0.2f, 0.4f, 1.0f));
  for (const auto& load : scenario.loads)
    markers.markers.push_back(forceArrow(load, frame, id++, largest > 0 ? 0.05 / largest : 0.0));
  return markers;
}

visualization_msgs::Marker meshMarker(const demnerf::core::TriangleMesh& mesh, const std::string& frame) {
  visualization_msgs::Marker marker;
  marker.header.frame_id = frame;
  marker.header.stamp = ros::Time::now();
  marker.ns = "nerf_mesh";
  marker.type = visualization_msgs::Marker::TRIANGLE_LIST;
  marker.action = visualization_msgs::Marker::ADD;
  marker.pose.orientation.w = 1.0;
  marker.scale.x = marker.scale.y = marker.scale.z = 1.0;
  marker.color.r = 0.8f;
  marker.color.g = 0.6f;
  marker.color.b = 0.4f;
  marker.color.a = 0.6f;
  marker.points.reserve(mesh.faces.size() * 3);
  for (const auto& face : mesh.faces) {
    for (int corner : face) {
      geometry_msgs::Point point;
      point.x = mesh.vertices[corner].x();
      point.y = mesh.vertices[corner].y();
      point.z = mesh.vertices[corner].z();
      marker.points.push_back(point);
    }
  }
  return marker;
}

}  // namespace dem_nerf
