# Hardens the C++ decoders that lcm-gen 1.3.1 emits (run as: cmake -DHEADERS=a.hpp|b.hpp -P this).
# Its generated _decodeNoHash trusts two things an attacker on the bus controls:
#  - a string length of 0 or less: `assign(ptr, len - 1)` then asks for ~2^64 bytes and throws
#    std::length_error out of the LCM callback (found by tests/fuzz/lcm_messages_fuzz.cpp);
#  - an array count: `resize(count)` with a negative or huge count allocates before any byte of
#    the elements is checked.
# Every string needs at least its NUL byte and every array element at least one byte, so both
# are bounded by the bytes left; anything else is a decode error (-1), as for any short buffer.
string(REPLACE "|" ";" HEADERS "${HEADERS}")
foreach(h ${HEADERS})
  file(READ ${h} text)
  string(REGEX REPLACE "if\\(__([A-Za-z0-9_]+)_len__ > maxlen - pos\\) return -1;"
         "if(__\\1_len__ < 1 || __\\1_len__ > maxlen - pos) return -1;" text "${text}")
  string(REGEX REPLACE "\n( *)this->([A-Za-z0-9_]+)\\.resize\\(this->([A-Za-z0-9_]+)\\);"
         "\n\\1if(this->\\3 < 0 || this->\\3 > maxlen - pos) return -1;\n\\1this->\\2.resize(this->\\3);"
         text "${text}")
  file(WRITE ${h} "${text}")
endforeach()
