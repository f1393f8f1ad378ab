// How many enumerators an enum has, at compile time: what a table over an enum (wire.hpp's, the
// protocols' conventions.hpp) checks itself against, so that a new enumerator no table lists is a
// compile error rather than a value that falls through a lookup.
//
// C++17 has no reflection; this reads the one place a compiler names an enumerator. GCC and Clang
// spell a template argument that is an enumerator by its name ("... V = chasles::controller::Mode::kHolding]")
// and a value that names none as a cast ("... V = (chasles::controller::Mode)7]"), as magic_enum
// relies on. Every value an int8_t holds is tried, so an enum counted here has its enumerators in
// [-128, 127] (every enum that crosses chasles's wire does: the wire's constants are int8_t).
#pragma once

#include <cstddef>
#include <string_view>
#include <utility>

namespace chasles::controller::enumerators {

/// Whether V is one of Enum's named enumerators.
template <typename Enum, Enum V>
constexpr bool is_named() {
#if defined(__GNUC__) || defined(__clang__)
  constexpr std::string_view signature = __PRETTY_FUNCTION__;
  constexpr std::size_t at = signature.rfind("V = ");
  static_assert(at != std::string_view::npos, "the compiler spells __PRETTY_FUNCTION__ in a way not known here");
  return signature[at + 4] != '(';
#else
#error "enumerators.hpp reads GCC's or Clang's __PRETTY_FUNCTION__"
#endif
}

template <typename Enum, int... I>
constexpr int count_named(std::integer_sequence<int, I...> /*values + 128*/) {
  return (0 + ... + (is_named<Enum, static_cast<Enum>(I - 128)>() ? 1 : 0));
}

/// The number of Enum's enumerators with a value in [-128, 127] (an enumerator given twice, as two
/// names of one value, counts once).
template <typename Enum>
constexpr int count() {
  return count_named<Enum>(std::make_integer_sequence<int, 256>{});
}

}  // namespace chasles::controller::enumerators
