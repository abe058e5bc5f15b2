// The number of members of an aggregate struct, counted by the compiler: the largest N for which
// T{x1, ..., xN} compiles, each x converting to any type. It guards the settings table
// (config_fields.cpp): a member added to a config struct changes its count, and the table's
// static_assert and test fail until the member is in the table (or listed as left out).
// sizeof was the other candidate and is weaker: a bool or int added into padding leaves it unchanged.
// Works for the config structs (default member initializers, nested structs, std::array, Eigen
// types, std::optional); not for structs with base classes, C arrays or reference members.
// Private to pl_client (and its tests).
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>

namespace pl::client::detail {

// Converts to anything; only ever named in unevaluated contexts.
struct AnyMember {
  template <class T>
  operator T() const;  // NOLINT(google-explicit-constructor): the point is the implicit conversion
};

template <class T, class Void, class... A>
struct BraceConstructible : std::false_type {};
template <class T, class... A>
struct BraceConstructible<T, std::void_t<decltype(T{std::declval<A>()...})>, A...> : std::true_type {};

template <class T, class... A>
constexpr std::size_t member_count() {
  static_assert(std::is_aggregate_v<T>, "member_count counts the members of an aggregate struct");
  if constexpr (BraceConstructible<T, void, A..., AnyMember>::value)
    return member_count<T, A..., AnyMember>();
  else
    return sizeof...(A);
}

}  // namespace pl::client::detail
