// SPDX-License-Identifier: MIT
// somm — a minimal contiguous view (pointer + size) for the public headers, which must compile as C++17
// (std::span is C++20). Converts implicitly from anything with data() and size() (std::vector, std::array,
// std::span, std::string_view, another Span of convertible elements), and is a range (begin/end are pointers).
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

namespace somm {

template <class T>
class Span {
 public:
  using element_type = T;
  using value_type = std::remove_cv_t<T>;
  using size_type = std::size_t;
  using pointer = T*;
  using iterator = T*;

  constexpr Span() noexcept = default;
  constexpr Span(T* data, std::size_t size) noexcept : data_(data), size_(size) {}
  template <class C, class P = decltype(std::declval<C&>().data()),
            class = std::enable_if_t<std::is_convertible_v<P, T*> &&
                                     std::is_same_v<std::remove_cv_t<std::remove_pointer_t<P>>, value_type> &&
                                     !std::is_same_v<std::remove_cv_t<std::remove_reference_t<C>>, Span>>,
            class = decltype(std::declval<C&>().size())>
  constexpr Span(C&& c) noexcept
      : data_(c.data()), size_(std::size_t(c.size())) {}  // NOLINT(google-explicit-constructor)
  template <std::size_t N>
  constexpr Span(T (&a)[N]) noexcept : data_(a), size_(N) {}  // NOLINT(google-explicit-constructor)

  constexpr T* data() const noexcept { return data_; }
  constexpr std::size_t size() const noexcept { return size_; }
  constexpr std::size_t size_bytes() const noexcept { return size_ * sizeof(T); }
  constexpr bool empty() const noexcept { return size_ == 0; }
  constexpr T& operator[](std::size_t i) const noexcept { return data_[i]; }
  constexpr T& front() const noexcept { return data_[0]; }
  constexpr T& back() const noexcept { return data_[size_ - 1]; }
  constexpr T* begin() const noexcept { return data_; }
  constexpr T* end() const noexcept { return data_ + size_; }
  constexpr Span first(std::size_t n) const noexcept { return Span(data_, n); }
  constexpr Span last(std::size_t n) const noexcept { return Span(data_ + size_ - n, n); }
  constexpr Span subspan(std::size_t offset) const noexcept { return Span(data_ + offset, size_ - offset); }
  constexpr Span subspan(std::size_t offset, std::size_t n) const noexcept { return Span(data_ + offset, n); }

 private:
  T* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace somm
