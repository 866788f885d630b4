# Run after lcm-gen --cpp: cmake -DHEADERS="a.hpp;b.hpp" -P bound_lengths.cmake
#
# lcm-gen's C++ decoders trust two kinds of length read from the wire, so that a malformed
# message could cost gigabytes or throw where decode() should just return -1 (which the Bus
# counts as a decode error and the log tools skip):
# - A variable-length array is resized to its count before the bytes left are checked
#   (lcm-proj/lcm#164): a 57-byte POINTS declaring 1e8 points made its receiver allocate and
#   zero 2.3 GB for 9 s before the decode failed; a negative count threw from resize().
#   Every element takes at least one byte on the wire, so a count that is negative or beyond
#   the bytes left is refused before anything is allocated.
# - A string's length (its bytes and the terminating NUL) is checked against the bytes left but
#   not against 1: a length of 0 or below threw from std::string::assign.
set(resize "\n( +)this->([A-Za-z0-9_]+)\\.resize\\(this->([A-Za-z0-9_]+)\\);")
set(resize_guarded "\n\\1if (this->\\3 < 0 || this->\\3 > maxlen - pos) return -1;\n\\1this->\\2.resize(this->\\3);")
set(string_check "if\\((__[A-Za-z0-9_]+_len(__)?) > maxlen - pos\\) return -1")
set(string_check_guarded "if (\\1 < 1 || \\1 > maxlen - pos) return -1")
foreach(header ${HEADERS})
  file(READ ${header} text)
  string(REGEX MATCHALL "resize\\(this->" arrays "${text}")
  string(REGEX MATCHALL "${string_check}" strings "${text}")
  string(REGEX REPLACE "${resize}" "${resize_guarded}" text "${text}")
  string(REGEX REPLACE "${string_check}" "${string_check_guarded}" text "${text}")
  string(REGEX MATCHALL "< 0 \\|\\| this->[A-Za-z0-9_]+ > maxlen - pos\\) return -1" arrays_bounded "${text}")
  string(REGEX MATCHALL "< 1 \\|\\| __[A-Za-z0-9_]+ > maxlen - pos\\) return -1" strings_bounded "${text}")
  list(LENGTH arrays n_arrays)
  list(LENGTH strings n_strings)
  list(LENGTH arrays_bounded m_arrays)
  list(LENGTH strings_bounded m_strings)
  if(NOT n_arrays EQUAL m_arrays OR NOT n_strings EQUAL m_strings)
    message(FATAL_ERROR "${header}: bounded ${m_arrays} of its ${n_arrays} variable-length arrays and "
                        "${m_strings} of its ${n_strings} strings; has lcm-gen's output changed?")
  endif()
  file(WRITE ${header} "${text}")
endforeach()
