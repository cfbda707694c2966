// CiA 306 electronic data sheets (EDS) and device configuration files (DCF):
// a tolerant, precise reader. Tolerant of what real files do (case and spaces
// in section names and keys, CRLF, ';' comments, decimal / hex / octal
// numbers everywhere a number goes (flags included), $NODEID terms in any
// order and case, empty keys as not given,
// CompactSubObj, ObjFlags); every rejection is a ConfigError
// "file:line: [section] key: what was expected, got 'value'".
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "config/profile.hpp"

namespace cansim::config {

// One "key=value" line.
struct EdsKey {
  std::string name;   // as written
  std::string value;  // without surrounding blanks
  // A string value: verbatim after '=' (blanks kept), or after the blanks that
  // follow '=' when the line spaces the key from '=' ("Key = Value").
  std::string text;
  int line = 0;
  std::string key;  // the name in lower case without blanks, as keys are compared
};

struct EdsSection {
  std::string name;  // as written, without the brackets
  int line = 0;
  std::string key;  // the name in lower case without blanks
  std::vector<EdsKey> keys;
  // Case- and space-insensitive ("lowlimit" finds "Low Limit").
  const EdsKey* find(std::string_view key) const;
};

struct EdsDocument {
  std::string file;
  std::vector<EdsSection> sections;
  const EdsSection* find(std::string_view section) const;  // case- and space-insensitive
};

// Splits text into sections and keys. Rejects a line that is neither a
// section, a key nor a comment, a key before the first section, a repeated
// section and a repeated key within a section.
EdsDocument parse_eds(const std::string& text, const std::string& file);
EdsDocument load_eds_file(const std::string& path);

// The profile a device description defines: the object dictionary (types,
// access, defaults with $NODEID, limits, PDO mapping; a DCF's ParameterValue
// wins over DefaultValue), the "generic" personality, and the node options the
// file states (LSS support, bit rates, dummy mapping). The only place where an
// EDS becomes a Profile.
// `strict`: in strict mode (an EDS has no quirks: its options stay CiA's).
// What real masters tolerate (docs/eds-dbc.md: a SubNumber or
// SupportedObjects that miscounts, a listed object without its section, the
// default SDO server's COB-IDs other than 600h / 580h + node-ID, NodeID=0 /
// Baudrate=0 for "not set", a DOMAIN "0", a REAL as IEEE 754 bits, $NODEID
// in a limit) loads with one warning per kind in Profile::warnings
// ("file:line: [section] key: expected ..., got '...'; what was done");
// `strict_eds` (`cansimd --strict-eds`) makes each of them an error.
Profile profile_from_eds(const EdsDocument& doc, bool strict = false, bool strict_eds = false);
Profile load_eds_profile(const std::string& path, bool strict = false, bool strict_eds = false);

// True for a file name ending in .eds or .dcf (any case).
bool is_device_description(const std::string& path);

// CiA 306 §4.2 integer: decimal, 0x hexadecimal or 0-prefixed octal, with sign.
bool parse_eds_integer(std::string_view text, std::int64_t& out);

}  // namespace cansim::config
