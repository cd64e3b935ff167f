#pragma once
/// Tensor: a dense float32 array with a shape, row-major (C order) strides and owned data.
///
/// Every tensor is contiguous: strides()[i] = product of shape()[i+1..]. The engine never makes
/// strided views; an op that needs another layout writes a new tensor, which keeps every buffer's
/// meaning readable from its shape alone. Feature maps are [N, C, H, W] as in PyTorch; token
/// sequences are [N, L, C].
#include <cstdint>
#include <initializer_list>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "gimm/core/error.hpp"
#include "gimm/core/huge_pages.hpp"
#include "gimm/nn/tensor_pool.hpp"

namespace gimm::nn {

using Shape = std::vector<std::int64_t>;

/// "[2, 64, 32, 32]", for error messages.
inline std::string shape_string(const Shape& shape) {
  std::ostringstream out;
  out << '[';
  for (std::size_t i = 0; i < shape.size(); ++i) out << (i ? ", " : "") << shape[i];
  out << ']';
  return out.str();
}

/// Number of elements of a shape; throws on a negative extent or an overflowing product.
inline std::int64_t shape_numel(const Shape& shape) {
  // The strides multiply every extent but the first, so the product of the non-zero extents
  // must stay in range too: [0, 2^62, 2^62] has no element but overflows its strides.
  std::int64_t n = 1, span = 1;
  for (std::int64_t d : shape) {
    GIMM_CHECK(d >= 0, "tensor: negative extent in shape " << shape_string(shape));
    const std::int64_t extent = d == 0 ? 1 : d;
    GIMM_CHECK(span <= (std::int64_t{1} << 40) / extent,
               "tensor: shape " << shape_string(shape) << " is too large");
    span *= extent;
    n *= d;
  }
  return n;
}

class Tensor {
 public:
  Tensor() = default;
  /// Zero-filled tensor of the given shape, in a kept buffer when one fits (tensor_pool.hpp).
  explicit Tensor(Shape shape, float fill = 0.0f) : shape_(std::move(shape)) {
    const auto n = static_cast<std::size_t>(shape_numel(shape_));
    data_ = TensorPool::instance().take(n);
    reserve_huge(data_, n);  // a large activation: huge pages before its first touch
    data_.assign(n, fill);
    update_strides();
  }
  Tensor(std::initializer_list<std::int64_t> shape) : Tensor(Shape(shape)) {}
  /// Takes ownership of `data`, whose size must equal the shape's element count.
  Tensor(Shape shape, std::vector<float> data) : shape_(std::move(shape)), data_(std::move(data)) {
    GIMM_CHECK(static_cast<std::int64_t>(data_.size()) == shape_numel(shape_),
               "tensor: " << data_.size() << " values do not fill shape " << shape_string(shape_));
    update_strides();
  }
  Tensor(const Tensor&) = default;
  Tensor(Tensor&&) noexcept = default;
  Tensor& operator=(const Tensor&) = default;
  Tensor& operator=(Tensor&& other) noexcept {
    if (this != &other) {
      TensorPool::instance().give(std::move(data_));  // the storage replaced is kept
      shape_ = std::move(other.shape_);
      strides_ = std::move(other.strides_);
      data_ = std::move(other.data_);
    }
    return *this;
  }
  /// The storage goes back to the pool (tensor_pool.hpp).
  ~Tensor() { TensorPool::instance().give(std::move(data_)); }

  const Shape& shape() const { return shape_; }
  const Shape& strides() const { return strides_; }
  int rank() const { return static_cast<int>(shape_.size()); }
  /// Extent of axis `axis`; negative counts from the end (-1 = last).
  std::int64_t dim(int axis) const {
    const int r = rank();
    GIMM_CHECK(axis >= -r && axis < r,
               "tensor: axis " << axis << " out of range for shape " << shape_string(shape_));
    return shape_[static_cast<std::size_t>(axis < 0 ? axis + r : axis)];
  }
  std::int64_t numel() const { return static_cast<std::int64_t>(data_.size()); }
  bool empty() const { return data_.empty(); }

  float* data() { return data_.data(); }
  const float* data() const { return data_.data(); }
  std::vector<float>& values() { return data_; }
  const std::vector<float>& values() const { return data_; }

  float& operator[](std::int64_t i) { return data_[static_cast<std::size_t>(i)]; }
  float operator[](std::int64_t i) const { return data_[static_cast<std::size_t>(i)]; }

  /// Element at a full index (one coordinate per axis); bounds are checked.
  template <class... I>
  float& at(I... index) {
    return data_[offset({static_cast<std::int64_t>(index)...})];
  }
  template <class... I>
  float at(I... index) const {
    return data_[offset({static_cast<std::int64_t>(index)...})];
  }

  /// Same data, another shape with the same element count.
  Tensor reshaped(Shape shape) const& {
    Tensor copy = *this;
    return std::move(copy).reshaped(std::move(shape));
  }
  Tensor reshaped(Shape shape) && {
    GIMM_CHECK(shape_numel(shape) == numel(),
               "tensor: cannot reshape " << shape_string(shape_) << " to " << shape_string(shape));
    shape_ = std::move(shape);
    update_strides();
    return std::move(*this);
  }

  /// Throws unless the shape is exactly `expected`; `what` names the tensor in the message.
  void expect_shape(const Shape& expected, const std::string& what) const {
    GIMM_CHECK(shape_ == expected, what << ": expected shape " << shape_string(expected) << ", got "
                                        << shape_string(shape_));
  }
  /// Throws unless the rank is `r`.
  void expect_rank(int r, const std::string& what) const {
    GIMM_CHECK(rank() == r,
               what << ": expected a rank-" << r << " tensor, got shape " << shape_string(shape_));
  }

 private:
  std::size_t offset(std::initializer_list<std::int64_t> index) const {
    GIMM_CHECK(!data_.empty(),
               "tensor: no element to access in an empty tensor of shape " << shape_string(shape_));
    GIMM_CHECK(static_cast<int>(index.size()) == rank(),
               "tensor: " << index.size() << " indices for shape " << shape_string(shape_));
    std::int64_t flat = 0;
    int axis = 0;
    for (std::int64_t i : index) {
      GIMM_CHECK(i >= 0 && i < shape_[static_cast<std::size_t>(axis)],
                 "tensor: index " << i << " out of range on axis " << axis << " of shape "
                                  << shape_string(shape_));
      flat += i * strides_[static_cast<std::size_t>(axis++)];
    }
    return static_cast<std::size_t>(flat);
  }
  void update_strides() {
    strides_.assign(shape_.size(), 1);
    for (int i = rank() - 2; i >= 0; --i)
      strides_[static_cast<std::size_t>(i)] =
          strides_[static_cast<std::size_t>(i) + 1] * shape_[static_cast<std::size_t>(i) + 1];
  }

  Shape shape_;
  Shape strides_;
  std::vector<float> data_;
};

}  // namespace gimm::nn
