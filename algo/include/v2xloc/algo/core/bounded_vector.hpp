// Fixed-capacity containers. Capacity lives in the type (FixedVector<T, N>); algorithms take the
// size-free base (BoundedVector<T>) or a std::span. Pushing past capacity never writes out of
// bounds: the element is dropped, counted in dropped(), and push_back returns false.
#pragma once

#include <cstddef>
#include <span>

namespace v2xloc {

template <class T>
class BoundedVector {
 public:
  // A view with size bookkeeping over caller-owned storage.
  explicit BoundedVector(std::span<T> storage) : data_(storage.data()), capacity_(storage.size()) {}
  BoundedVector(const BoundedVector&) = delete;
  BoundedVector& operator=(const BoundedVector&) = delete;

  bool push_back(const T& value) {
    if (size_ == capacity_) {
      ++dropped_;
      return false;
    }
    data_[size_++] = value;
    return true;
  }
  // Sets the size; a request beyond capacity is clamped and the excess counted.
  void resize(std::size_t n) {
    if (n > capacity_) {
      dropped_ += n - capacity_;
      n = capacity_;
    }
    size_ = n;
  }
  void pop_back() { if (size_ > 0) --size_; }
  void clear() { size_ = 0; dropped_ = 0; }
  bool full() const { return size_ == capacity_; }
  bool empty() const { return size_ == 0; }
  std::size_t size() const { return size_; }
  std::size_t capacity() const { return capacity_; }
  std::size_t dropped() const { return dropped_; }
  T& operator[](std::size_t i) { return data_[i]; }
  const T& operator[](std::size_t i) const { return data_[i]; }
  T& back() { return data_[size_ - 1]; }
  T* data() { return data_; }
  const T* data() const { return data_; }
  T* begin() { return data_; }
  T* end() { return data_ + size_; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }
  std::span<T> span() { return {data_, size_}; }
  std::span<const T> span() const { return {data_, size_}; }
  std::span<T> storage() { return {data_, capacity_}; }

 protected:
  BoundedVector(T* data, std::size_t capacity) : data_(data), capacity_(capacity) {}

 private:
  T* data_;
  std::size_t capacity_;
  std::size_t size_ = 0;
  std::size_t dropped_ = 0;
};

// Owns N elements inline. Not copyable (the base points into this object); large instances
// belong in static storage, never on the stack.
template <class T, std::size_t N>
class FixedVector : public BoundedVector<T> {
 public:
  static constexpr std::size_t kCapacity = N;
  FixedVector() : BoundedVector<T>(storage_, N) {}

 private:
  T storage_[N];
};

}  // namespace v2xloc
