// Stacks and sequences as numpy arrays and dicts. A stack's arrays are views of its mapped tables
// (read-only; the mapping lives as long as any of them); the tables of a folder with a base lie in two
// mappings and are copied into one array.
#include <algorithm>
#include <memory>
#include <string>

#include <opencv2/imgproc.hpp>

#include "bindings.hpp"
#include "smseg/common/error.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::python {

namespace {

py::dict load_stack(const fs::path& work, int frame) {
  const stacks::StackManifest m = stacks::load_stack_manifest(work);
  auto stack = std::make_unique<stacks::FrameStack>(stacks::FrameStack::open(m, frame, m.is_labelled(frame)));
  const stacks::FrameStack* s = stack.get();
  py::capsule owner(stack.release(), [](void* p) { delete static_cast<stacks::FrameStack*>(p); });
  const py::ssize_t H = m.size.height, W = m.size.width, F = static_cast<py::ssize_t>(m.features.size());
  py::dict d;
  d["work"] = work.string();
  d["frame"] = frame;
  d["features"] = m.features;
  d["classes"] = m.classes;
  const std::size_t cells = std::size_t(H + 1) * std::size_t(W + 1);
  bool contiguous = true;
  for (py::ssize_t f = 1; f < F; ++f) contiguous = contiguous && s->sat(int(f)) == s->sat(0) + std::size_t(f) * cells;
  if (contiguous) {
    d["sat"] = view_array<double>({F, H + 1, W + 1}, s->sat(0), owner);
  } else {
    py::array_t<double> sat({F, H + 1, W + 1});
    for (py::ssize_t f = 0; f < F; ++f)
      std::copy_n(s->sat(int(f)), cells, sat.mutable_data() + std::size_t(f) * cells);
    d["sat"] = sat;
  }
  d["gray"] = view_array<std::uint8_t>({H, W}, s->gray(), owner);
  d["labels"] = s->labels() ? py::object(view_array<std::uint8_t>({H, W}, s->labels(), owner)) : py::none();
  return d;
}

py::dict stack_manifest(const fs::path& work) {
  const stacks::StackManifest m = stacks::load_stack_manifest(work);
  py::dict d;
  d["work"] = work.string();
  d["sequence"] = m.sequence.string();
  d["sequence_name"] = m.sequence_name;
  d["width"] = m.size.width;
  d["height"] = m.size.height;
  d["features"] = m.features;
  d["classes"] = m.classes;
  d["frames"] = m.frames;
  d["labelled_frames"] = m.labelled_frames;
  d["options"] = to_python(m.options);
  return d;
}

py::dict load_sequence(const fs::path& path) {
  const sequence::Sequence seq = sequence::load_sequence(path);
  py::list classes, colours;
  for (const auto& c : seq.classes) {
    classes.append(c.name);
    colours.append(py::make_tuple(c.rgb[0], c.rgb[1], c.rgb[2]));
  }
  py::dict d;
  d["manifest"] = seq.manifest.string();
  d["name"] = seq.name;
  d["kind"] = seq.kind == sequence::SequenceKind::Mono ? "mono" : "stereo";
  d["width"] = seq.size.width;
  d["height"] = seq.size.height;
  d["frame_count"] = seq.frame_count();
  d["labelled_frames"] = seq.labelled_frames;
  d["classes"] = classes;
  d["colours"] = colours;
  d["camera_height"] = seq.camera_height ? py::object(py::float_(*seq.camera_height)) : py::none();
  d["has_ground_truth_poses"] = !seq.gt_poses.empty();
  return d;
}

/// A cv::Mat's pixels as a new numpy array (images are decoded, so there is nothing to share).
template <class T>
py::array_t<T> copy_mat(const cv::Mat& mat) {
  std::vector<py::ssize_t> shape{mat.rows, mat.cols};
  if (mat.channels() > 1) shape.push_back(mat.channels());
  const cv::Mat c = mat.isContinuous() ? mat : mat.clone();
  std::vector<T> values(reinterpret_cast<const T*>(c.data), reinterpret_cast<const T*>(c.data) + c.total() * c.channels());
  return array_from_vector(std::move(values), std::move(shape));
}

py::dict read_frame(const fs::path& path, int frame) {
  const sequence::Sequence seq = sequence::load_sequence(path);
  if (frame < 0 || frame >= seq.frame_count())
    throw Error(seq.manifest.string(), "frames", "frame " + std::to_string(frame) + " is not in 0.." +
                                                     std::to_string(seq.frame_count() - 1));
  cv::Mat rgb;
  cv::cvtColor(seq.load_left(frame), rgb, cv::COLOR_BGR2RGB);
  py::dict d;
  d["frame"] = frame;
  d["left"] = copy_mat<std::uint8_t>(rgb);
  d["labels"] = seq.is_labelled(frame) ? py::object(copy_mat<std::uint8_t>(seq.load_labels(frame))) : py::none();
  return d;
}

}  // namespace

void bind_data(py::module_& m) {
  m.def("load_stack", &load_stack, py::arg("work"), py::arg("frame"),
        "One frame's feature stack of a work folder: sat (F, H+1, W+1), gray, labels (or None), read-only "
        "views of the memory-mapped files; features, classes.");
  m.def("stack_manifest", &stack_manifest, py::arg("work"), "A work folder's stacks.json, checked, as a dict.");
  m.def("load_sequence", &load_sequence, py::arg("path"), "A sequence folder's manifest, checked, as a dict.");
  m.def("read_frame", &read_frame, py::arg("path"), py::arg("frame"),
        "One frame of a sequence: left image (H, W, 3) RGB, labels (H, W) class positions, 255 void (or None).");
}

}  // namespace smseg::python
