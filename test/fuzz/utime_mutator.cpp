// libFuzzer's mutator for the targets whose input is records of LCM messages (fuzz_nodes,
// fuzz_camera): one mutation in four sets one message's utime (fuzz::mutateUtime), the others are
// libFuzzer's own. A fault that needs those 8 bytes set just so (INT64_MIN, the top bit flipped)
// was out of reach of byte-level mutation: 25 minutes of fuzz_nodes did not find the planner's
// old overflow at a pose stamped INT64_MIN (its check taken out); with this mutation three 300 s
// runs found it, in 38 to 58 s (README, Building by hand). Linked into the libFuzzer build only.
#include "fuzz.hpp"

extern "C" std::size_t LLVMFuzzerMutate(std::uint8_t* data, std::size_t size, std::size_t max_size);

extern "C" std::size_t LLVMFuzzerCustomMutator(std::uint8_t* data, std::size_t size, std::size_t max_size,
                                               unsigned seed) {
  if (seed % 4 == 0 && depowder::fuzz::mutateUtime(data, size, seed / 4)) return size;
  return LLVMFuzzerMutate(data, size, max_size);
}
