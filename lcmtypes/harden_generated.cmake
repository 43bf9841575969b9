# Hardens the C++ decoders that lcm-gen 1.3.1 emits (run as: cmake -DHEADERS=a.hpp|b.hpp
# -DSTAGE=<lcm-gen's output folder> -DOUT=<include folder> -P this): each header named in HEADERS
# (its path under OUT) is read from STAGE, hardened, and written to OUT only when its text differs
# from what OUT holds (an unchanged message's header keeps its time stamp: nothing rebuilds).
# Its generated _decodeNoHash trusts two things an attacker on the bus controls:
#  - a string length of 0 or less: `assign(ptr, len - 1)` then asks for ~2^64 bytes and throws
#    std::length_error out of the LCM callback (found by tests/fuzz/lcm_messages_fuzz.cpp);
#  - an array count: `resize(count)` with a negative or huge count allocates before any byte of
#    the elements is checked.
# Every string needs at least its NUL byte and every array element at least one byte, so both
# are bounded by the bytes left; anything else is a decode error (-1), as for any short buffer.
string(REPLACE "|" ";" HEADERS "${HEADERS}")
foreach(h ${HEADERS})
  file(RELATIVE_PATH rel ${OUT} ${h})
  file(READ ${STAGE}/${rel} text)
  string(REGEX REPLACE "if\\(__([A-Za-z0-9_]+)_len__ > maxlen - pos\\) return -1;"
         "if(__\\1_len__ < 1 || __\\1_len__ > maxlen - pos) return -1;" text "${text}")
  # Elements of string arrays use a variable named __elem_len.
  string(REGEX REPLACE "if\\(__elem_len > maxlen - pos\\) return -1;"
         "if(__elem_len < 1 || __elem_len > maxlen - pos) return -1;" text "${text}")
  # Any resize to a count off the wire, including inner dimensions (this->a[i].resize(this->n)).
  string(REGEX REPLACE "\n( *)this->([A-Za-z0-9_]+(\\[[a-z0-9]+\\])*)\\.resize\\(this->([A-Za-z0-9_]+)\\);"
         "\n\\1if(this->\\4 < 0 || this->\\4 > maxlen - pos) return -1;\n\\1this->\\2.resize(this->\\4);"
         text "${text}")
  # Refuse to build with a decoder left unguarded (a new lcm-gen output shape, say).
  string(REGEX MATCHALL "\\.assign\\(" assigns "${text}")
  string(REGEX MATCHALL "< 1 \\|\\| __" string_guards "${text}")
  string(REGEX MATCHALL "\\.resize\\(" resizes "${text}")
  string(REGEX MATCHALL "< 0 \\|\\| this->" array_guards "${text}")
  list(LENGTH assigns n_assign)
  list(LENGTH string_guards n_string_guard)
  list(LENGTH resizes n_resize)
  list(LENGTH array_guards n_array_guard)
  if(NOT n_assign EQUAL n_string_guard OR NOT n_resize EQUAL n_array_guard)
    message(FATAL_ERROR "harden_generated.cmake: ${h}: ${n_assign} string decodes with "
                        "${n_string_guard} guards, ${n_resize} array resizes with "
                        "${n_array_guard} guards; extend the patterns for this lcm-gen output")
  endif()
  set(old "")
  if(EXISTS ${h})
    file(READ ${h} old)
  endif()
  if(NOT old STREQUAL text)
    file(WRITE ${h} "${text}")
  endif()
endforeach()
