// CANSIM_ASAN: defined when AddressSanitizer is on (gcc says
// __SANITIZE_ADDRESS__, clang __has_feature(address_sanitizer)). ASan owns
// operator new / delete and the heap, so tests that count allocations or
// read mallinfo2 take another way or skip under it.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define CANSIM_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CANSIM_ASAN 1
#endif
#endif
