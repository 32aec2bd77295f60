// Whether this build is instrumented with AddressSanitizer: GCC defines
// __SANITIZE_ADDRESS__, clang answers __has_feature(address_sanitizer)
// (scripts/test-sanitizers builds with clang, scripts/fuzz too).
#ifndef MVBRDF_CORE_BASE_SANITIZERS_H_
#define MVBRDF_CORE_BASE_SANITIZERS_H_

namespace mvbrdf::base {

#if defined(__SANITIZE_ADDRESS__)
inline constexpr bool kAddressSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
inline constexpr bool kAddressSanitizer = true;
#else
inline constexpr bool kAddressSanitizer = false;
#endif
#else
inline constexpr bool kAddressSanitizer = false;
#endif

}  // namespace mvbrdf::base

#endif  // MVBRDF_CORE_BASE_SANITIZERS_H_
