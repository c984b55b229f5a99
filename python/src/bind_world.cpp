// The world (world/, config/track_loader.hpp): tracks with their gates and obstacles, and ray
// casting against them with numpy rays in and distances out.
#include <cstdint>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "dronetwin/config/track_loader.hpp"
#include "dronetwin/core/error.hpp"
#include "dronetwin/world/collision_shape.hpp"
#include "dronetwin/world/ray_cast.hpp"

namespace dronetwin::python {

namespace {

const char* shape_name(Obstacle::Shape s) {
  switch (s) {
    case Obstacle::Shape::kBox:
      return "box";
    case Obstacle::Shape::kCylinder:
      return "cylinder";
    case Obstacle::Shape::kSphere:
      return "sphere";
  }
  return "?";
}

// An (N, 3) C-contiguous float64 array, refused by name otherwise.
py::array_t<double> rows_of_three(py::handle obj, const char* what) {
  if (!py::isinstance<py::array_t<double>>(obj) ||
      !py::array(py::reinterpret_borrow<py::object>(obj)).dtype().is(py::dtype::of<double>()))
    throw py::type_error(std::string(what) +
                         ": expected a float64 numpy array of shape (N, 3), got " +
                         describe_object(obj));
  auto a = py::reinterpret_borrow<py::array_t<double>>(obj);
  if (a.ndim() != 2 || a.shape(1) != 3)
    throw py::value_error(std::string(what) + ": expected shape (N, 3), got " +
                          describe_object(obj));
  return py::array_t<double, py::array::c_style | py::array::forcecast>(a);
}

}  // namespace

void bind_world(py::module_& m) {
  py::class_<CollisionShape> shape(
      m, "CollisionShape",
      "What stands for a vehicle when it touches the scene: a sphere or a box fixed in the body "
      "frame (docs/model-format.md, `collision:`).\n\n"
      "    spec.collision = dronetwin.CollisionShape.box([0.3, 0.3, 0.08])");
  shape
      .def_static(
          "sphere",
          [](double r, py::handle c) {
            return CollisionShape::sphere(
                r, c.is_none() ? Vec3(Vec3::Zero()) : to_fixed<3>(c, "center_B_m"));
          },
          py::arg("radius_m"), py::arg("center_B_m") = py::none(),
          "A sphere of radius_m (m) centred at center_B_m (body frame, default the origin).")
      .def_static(
          "box",
          [](py::handle h, py::handle c) {
            return CollisionShape::box(
                to_fixed<3>(h, "half_size_m"),
                c.is_none() ? Vec3(Vec3::Zero()) : to_fixed<3>(c, "center_B_m"));
          },
          py::arg("half_size_m"), py::arg("center_B_m") = py::none(),
          "A box of half extents half_size_m along the body axes (m), centred at center_B_m "
          "(body frame, default the origin).")
      .def_property_readonly(
          "kind", [](const CollisionShape& c) { return std::string(collision_kind_name(c.kind)); })
      .def_readonly("radius_m", &CollisionShape::radius_m)
      .def_property_readonly("half_size_m",
                             [](const CollisionShape& c) { return copy_of(c.half_size_m); })
      .def_property_readonly("center_B_m",
                             [](const CollisionShape& c) { return copy_of(c.center_B_m); })
      .def_property_readonly("bounding_radius_m", &CollisionShape::bounding_radius_m)
      .def("__repr__", [](const CollisionShape& c) {
        return c.kind == CollisionShape::Kind::kSphere
                   ? detail::concat("CollisionShape.sphere(", c.radius_m, ")")
                   : detail::concat("CollisionShape.box([", c.half_size_m.transpose(), "])");
      });

  py::class_<Track, std::shared_ptr<Track>>(
      m, "Track",
      "A racing track / world: gates in racing order, the arena, obstacles "
      "(docs/track-format.md). Read with load_track().")
      .def_readonly("name", &Track::name)
      .def_readonly("closed", &Track::closed)
      .def_property_readonly("num_gates", [](const Track& t) { return t.gates.size(); })
      .def_property_readonly("gate_names",
                             [](const Track& t) {
                               py::list out;
                               for (const Gate& g : t.gates) out.append(g.name);
                               return out;
                             })
      .def_property_readonly(
          "gates",
          [](const Track& t) {
            py::list out;
            for (const Gate& g : t.gates) {
              py::list corners, axes;
              for (const Vec3& c : g.bar_corners()) corners.append(copy_of(c));
              for (int col = 0; col < 3; ++col) axes.append(copy_of(Vec3(g.axes.col(col))));
              out.append(py::dict(py::arg("name") = g.name, py::arg("center") = copy_of(g.center_m),
                                  py::arg("axes") = axes, py::arg("width_m") = g.width_m,
                                  py::arg("height_m") = g.height_m,
                                  py::arg("frame_width_m") = g.frame_width_m,
                                  py::arg("bar_corners") = corners));
            }
            return out;
          },
          "One dict per gate in racing order: name, center (m), axes (the passage direction, the "
          "width axis and the up axis), width_m, height_m, frame_width_m and bar_corners (the "
          "four corners where the frame's bars' axes meet, m).")
      .def_property_readonly(
          "obstacles",
          [](const Track& t) {
            py::list out;
            for (const Obstacle& o : t.obstacles)
              out.append(py::dict(py::arg("name") = o.name, py::arg("type") = shape_name(o.shape),
                                  py::arg("center") = copy_of(o.center_m),
                                  py::arg("half_size") = copy_of(o.half_size_m)));
            return out;
          },
          "One dict per obstacle: name, type ('box', 'cylinder', 'sphere'), center and half_size "
          "(m; cylinder (r, r, h/2), sphere (r, r, r)).")
      .def_property_readonly("length_m", &Track::length_m);
  m.def("load_track", &load_track, py::arg("path"), "Reads a track file (docs/track-format.md).");
  m.def(
      "cast_rays",
      [](const Track& track, py::handle origins, py::handle directions, double max_range_m) {
        const py::array_t<double> o = rows_of_three(origins, "cast_rays: origins");
        const py::array_t<double> d = rows_of_three(directions, "cast_rays: directions");
        require(o.shape(0) == d.shape(0), "cast_rays: ", o.shape(0), " origins but ", d.shape(0),
                " directions");
        const auto n = static_cast<std::size_t>(o.shape(0));
        py::array_t<double> distance(static_cast<py::ssize_t>(n));
        py::array_t<std::uint8_t> kind(static_cast<py::ssize_t>(n));
        py::array_t<std::int32_t> index(static_cast<py::ssize_t>(n));
        std::vector<RayHit::Kind> kinds(n);
        {
          const py::gil_scoped_release release;
          cast_rays(track, o.data(), d.data(), n, max_range_m, distance.mutable_data(),
                    kinds.data(), index.mutable_data());
        }
        for (std::size_t i = 0; i < n; ++i)
          kind.mutable_data()[i] = static_cast<std::uint8_t>(kinds[i]);
        return py::make_tuple(distance, kind, index);
      },
      py::arg("track"), py::arg("origins"), py::arg("directions"), py::arg("max_range_m"),
      "Casts N rays (origins and unit directions as (N, 3) float64 arrays) against the track's "
      "ground, obstacles and gate frames. Returns (distance_m, kind, index): distance inf beyond "
      "max_range_m; kind 0 nothing, 1 ground, 2 obstacle, 3 gate; index into the obstacles or "
      "gates (-1 otherwise). A ray that starts inside a shape hits it at 0. Bad rays are named "
      "with their index (ValueError).");
}

}  // namespace dronetwin::python
