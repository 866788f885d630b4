# Run after lcm-gen --cpp: cmake -DHEADERS="a.hpp;b.hpp" -P bound_arrays.cmake
#
# lcm-gen's C++ decoders resize a variable-length array to the count read from the wire before
# they check that the buffer holds that many elements (lcm-proj/lcm#164): a 57-byte POINTS
# message declaring 1e8 points made its receiver allocate and zero 2.3 GB for 9 s before the
# decode failed, and a negative count threw from resize(). Every element takes at least one
# byte on the wire, so a count that is negative or beyond the bytes left is refused
# (decode returns -1, counted by the Bus as a decode error) before anything is allocated.
set(resize "\n( +)this->([A-Za-z0-9_]+)\\.resize\\(this->([A-Za-z0-9_]+)\\);")
set(guarded "\n\\1if (this->\\3 < 0 || this->\\3 > maxlen - pos) return -1;\n\\1this->\\2.resize(this->\\3);")
foreach(header ${HEADERS})
  file(READ ${header} text)
  string(REGEX MATCHALL "resize\\(this->" counted "${text}")
  string(REGEX REPLACE "${resize}" "${guarded}" text "${text}")
  string(REGEX MATCHALL "< 0 \\|\\| this->[A-Za-z0-9_]+ > maxlen - pos\\) return -1" bounded "${text}")
  list(LENGTH counted n)
  list(LENGTH bounded m)
  if(NOT n EQUAL m)
    message(FATAL_ERROR "${header}: bounded ${m} of its ${n} variable-length arrays; has lcm-gen's output changed?")
  endif()
  file(WRITE ${header} "${text}")
endforeach()
