// Deterministic mutations of a good log file, for the readers' robustness
// tests (test_logs.cpp, test_dataflash.cpp): every mutated file must parse or
// end in an InputError: no crash, no hang, no other exception. Mutations
// (seeded): truncation at every 7th byte, single bit flips, 16-bit runs
// overwritten (length fields with large values).
#pragma once

#include "quadid/io.hpp"

#include <cstdint>
#include <cstring>
#include <random>
#include <string>

namespace quadid::testing {

template <class Parse>
void mutate_and_parse(const std::string& good, Parse parse, std::uint32_t seed, int* errors, int* oks,
                      int flips = 400, int overwrites = 300) {
  auto run = [&](const std::string& b) {
    try {
      parse(b);
      ++*oks;
    } catch (const InputError&) {
      ++*errors;
    }
  };
  for (std::size_t n = 0; n < good.size(); n += 7) run(good.substr(0, n));
  std::mt19937 rng(seed);
  std::uniform_int_distribution<std::size_t> pos(0, good.size() - 1);
  for (int k = 0; k < flips; ++k) {
    std::string b = good;
    b[pos(rng)] ^= static_cast<char>(1u << (rng() % 8));
    run(b);
  }
  for (int k = 0; k < overwrites; ++k) {
    std::string b = good;
    const std::size_t p = pos(rng) % (good.size() - 1);
    const auto v = static_cast<std::uint16_t>(rng());
    std::memcpy(&b[p], &v, 2);
    run(b);
  }
}

}  // namespace quadid::testing
