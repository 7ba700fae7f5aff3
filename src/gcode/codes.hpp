#pragma once
// Stable diagnostic codes. Never renumber or reuse one; README.md lists them all.
#include <string_view>

namespace postproc::gcode::codes {
// Errors: the program is refused.
inline constexpr std::string_view kUnexpectedChar = "PP-E101";
inline constexpr std::string_view kUnclosedComment = "PP-E102";
inline constexpr std::string_view kProgramNumber = "PP-E103";
inline constexpr std::string_view kUnknownG = "PP-E201";
inline constexpr std::string_view kModalConflict = "PP-E202";
inline constexpr std::string_view kRepeatedWord = "PP-E203";
inline constexpr std::string_view kMissingWord = "PP-E204";
inline constexpr std::string_view kOutOfRange = "PP-E205";
inline constexpr std::string_view kArcGeometry = "PP-E301";
inline constexpr std::string_view kRenumberRefused = "PP-E501";
inline constexpr std::string_view kUnitsRefused = "PP-E502";
inline constexpr std::string_view kLinearizeRefused = "PP-E503";
// Warnings: accepted, but not resolved (compensation refuses unless --pass-through).
inline constexpr std::string_view kTurningCycle = "PP-U201";
inline constexpr std::string_view kThreading = "PP-U202";
inline constexpr std::string_view kSpline = "PP-U203";
inline constexpr std::string_view kPolar = "PP-U204";
inline constexpr std::string_view kCylindrical = "PP-U205";
inline constexpr std::string_view kProbe = "PP-U206";
inline constexpr std::string_view kTiltedPlane = "PP-U207";
inline constexpr std::string_view kLatheDrill = "PP-U208";
inline constexpr std::string_view kUnknownPosition = "PP-U209";
inline constexpr std::string_view kVendorCycle = "PP-U210";
inline constexpr std::string_view kSubprogramCall = "PP-U211";
inline constexpr std::string_view kControlFlow = "PP-U212";
inline constexpr std::string_view kExpressionValue = "PP-U213";
inline constexpr std::string_view kAssignment = "PP-U214";
inline constexpr std::string_view kUnknownKeyword = "PP-U215";
inline constexpr std::string_view kMacroCall = "PP-U216";
inline constexpr std::string_view kCycleRepeat = "PP-U217";
inline constexpr std::string_view kIntegerInput = "PP-U218";
// Siemens dialect (reader round 2): Sinumerik motion addresses and declarations.
inline constexpr std::string_view kSiemensCorner = "PP-U240";     ///< CHF= CHR= RND= RNDM= not computed
inline constexpr std::string_view kSiemensSpaceArc = "PP-U241";   ///< CIP / CT arc not in a principal plane
inline constexpr std::string_view kSiemensGlobalVar = "PP-U242";  ///< GUD / undeclared variable read
inline constexpr std::string_view kSiemensTurnFraction = "PP-U243"; ///< TURN= not a whole number
inline constexpr std::string_view kSiemensArcWords = "PP-E240";   ///< AR= TURN= CR= I1= misused
inline constexpr std::string_view kSiemensGlobalFlow = "PP-E241";  ///< GUD value decides control flow / assignment
// Notes.
inline constexpr std::string_view kDialectGuess = "PP-N001";
inline constexpr std::string_view kDialectMismatch = "PP-N002";
inline constexpr std::string_view kTapeLeader = "PP-N003";
}  // namespace postproc::gcode::codes
