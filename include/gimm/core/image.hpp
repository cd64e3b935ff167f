#pragma once
/// Image<T>: a dense 2D image, row-major, indexed (row, col).
///
/// Pixel (row i, col j) has its centre at image coordinates (u, v) = (j, i): u grows to the
/// right along a row, v grows downward along a column. Storage: data()[i * cols() + j].
#include <cstddef>
#include <vector>

#include "gimm/core/error.hpp"

namespace gimm {

template <class T>
class Image {
 public:
  Image() = default;
  /// An image of `rows` x `cols` pixels, all equal to `fill`.
  Image(int rows, int cols, T fill = T{}) { assign(rows, cols, fill); }

  /// Make this a rows x cols image in the storage it has when that is large enough, so a buffer
  /// kept between calls is not allocated (and its pages touched for the first time) again. The
  /// pixels' values are unspecified: the caller overwrites every one.
  void resize(int rows, int cols) {
    check_size(rows, cols);
    data_.resize(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
    rows_ = rows;
    cols_ = cols;
  }
  /// Make this a rows x cols image with every pixel `fill`, in the storage it has when that is
  /// large enough (as resize()).
  void assign(int rows, int cols, T fill) {
    check_size(rows, cols);
    data_.assign(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols), fill);
    rows_ = rows;
    cols_ = cols;
  }

  int rows() const { return rows_; }
  int cols() const { return cols_; }
  std::size_t size() const { return data_.size(); }
  bool empty() const { return data_.empty(); }

  T& operator()(int row, int col) {
    GIMM_ASSERT(contains(row, col));
    return data_[index(row, col)];
  }
  const T& operator()(int row, int col) const {
    GIMM_ASSERT(contains(row, col));
    return data_[index(row, col)];
  }
  /// Bounds-checked access: throws gimm::Error naming the pixel and the image size.
  const T& at(int row, int col) const {
    GIMM_CHECK(contains(row, col), "Image::at: pixel (row " << row << ", col " << col
                                                            << ") outside " << rows_ << " x "
                                                            << cols_ << " image");
    return data_[index(row, col)];
  }
  bool contains(int row, int col) const {
    return row >= 0 && col >= 0 && row < rows_ && col < cols_;
  }

  T* data() { return data_.data(); }
  const T* data() const { return data_.data(); }
  std::vector<T>& storage() { return data_; }
  const std::vector<T>& storage() const { return data_; }

 private:
  static void check_size(int rows, int cols) {
    GIMM_CHECK(rows >= 0 && cols >= 0,
               "Image: rows and cols must be non-negative, got " << rows << " x " << cols);
  }
  std::size_t index(int row, int col) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(cols_) +
           static_cast<std::size_t>(col);
  }
  int rows_ = 0;
  int cols_ = 0;
  std::vector<T> data_;
};

}  // namespace gimm
