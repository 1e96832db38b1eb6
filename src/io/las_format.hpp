// The fixed layouts of LAS 1.0-1.4 that the reader and the writer share (ASPRS LAS specification
// R15, §2.4 public header block, §2.5 variable-length records, §2.6-§2.16 point data record
// formats 0-10). All values are little-endian.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

namespace sspc::io::las {

inline constexpr std::string_view kSignature = "LASF";

// Public header block sizes per minor version: 1.0-1.2 end after the min Z field, 1.3 adds the
// start of the waveform data packet record, 1.4 the extended VLRs and 64-bit point counts.
inline constexpr std::size_t kHeaderSize12 = 227;
inline constexpr std::size_t kHeaderSize13 = 235;
inline constexpr std::size_t kHeaderSize14 = 375;

inline constexpr std::size_t kVlrHeaderSize = 54;   // §2.5
inline constexpr std::size_t kEvlrHeaderSize = 60;  // §2.7

// Offsets of the header fields the reader needs (§2.4, Table 3).
inline constexpr std::size_t kOffVersionMajor = 24;
inline constexpr std::size_t kOffHeaderSize = 94;
inline constexpr std::size_t kOffPointDataOffset = 96;
inline constexpr std::size_t kOffVlrCount = 100;
inline constexpr std::size_t kOffPointFormat = 104;
inline constexpr std::size_t kOffRecordLength = 105;
inline constexpr std::size_t kOffLegacyCount = 107;
inline constexpr std::size_t kOffScale = 131;
inline constexpr std::size_t kOffOffset = 155;
inline constexpr std::size_t kOffBounds = 179;
inline constexpr std::size_t kOffWaveformStart = 227;
inline constexpr std::size_t kOffEvlrStart = 235;
inline constexpr std::size_t kOffEvlrCount = 243;
inline constexpr std::size_t kOffCount64 = 247;

inline constexpr int kMaxPointFormat = 10;
// Bytes each point data record format's own fields take (§2.6-§2.16); a record may be longer,
// the rest being extra bytes.
inline constexpr std::array<std::size_t, kMaxPointFormat + 1> kMinRecordLength = {
    20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};

// Global encoding bits (§2.4): bit 0 GPS time is adjusted standard time, bits 1-2 waveform data
// packets, bit 4 the CRS is WKT.
inline constexpr std::uint16_t kGlobalGpsStandard = 1u << 0;
inline constexpr std::uint16_t kGlobalWaveformBits = (1u << 1) | (1u << 2);
inline constexpr std::uint16_t kGlobalWkt = 1u << 4;

// Where the optional fields sit in a record, by format; -1 when the format lacks the field.
struct PointLayout {
  bool extended = false;  // formats 6-10: 4-bit returns, 8-bit classes, 16-bit scan angle
  int gps = -1;
  int rgb = -1;
  int nir = -1;
  int wave = -1;  // 29 bytes of waveform packet descriptor, which sspc does not keep
};

inline constexpr PointLayout point_layout(int format) {
  switch (format) {
    case 0: return {false, -1, -1, -1, -1};
    case 1: return {false, 20, -1, -1, -1};
    case 2: return {false, -1, 20, -1, -1};
    case 3: return {false, 20, 28, -1, -1};
    case 4: return {false, 20, -1, -1, 28};
    case 5: return {false, 20, 28, -1, 34};
    case 6: return {true, 22, -1, -1, -1};
    case 7: return {true, 22, 30, -1, -1};
    case 8: return {true, 22, 30, 36, -1};
    case 9: return {true, 22, -1, -1, 30};
    default: return {true, 22, 30, 36, 38};  // 10
  }
}

// Known records (§2.5.1-§2.5.3, §2.9): the CRS and the extra-bytes description.
inline constexpr std::string_view kUserProjection = "LASF_Projection";
inline constexpr std::string_view kUserSpec = "LASF_Spec";
inline constexpr std::uint16_t kRecordWkt = 2112;
inline constexpr std::uint16_t kRecordGeoKeys = 34735;
inline constexpr std::uint16_t kRecordGeoDoubles = 34736;
inline constexpr std::uint16_t kRecordGeoAscii = 34737;
inline constexpr std::uint16_t kRecordExtraBytes = 4;
// LASzip's record marks a compressed (LAZ) file; COPC's "info" record a cloud-optimised one.
inline constexpr std::string_view kUserLaszip = "laszip encoded";
inline constexpr std::uint16_t kRecordLaszip = 22204;
inline constexpr std::string_view kUserCopc = "copc";

}  // namespace sspc::io::las
