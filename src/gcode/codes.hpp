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
inline constexpr std::string_view kWordNotAllowed = "PP-E206";  // a word the block's G code does not take
inline constexpr std::string_view kControllerRefuses = "PP-E207";  // a state the controller itself refuses
inline constexpr std::string_view kGCodeSystemAmbiguous = "PP-E209";
inline constexpr std::string_view kCutterCompRefused = "PP-E220";  // LinuxCNC stops under cutter radius compensation  // Fanuc lathe G-code system A and B both evidenced
inline constexpr std::string_view kArcGeometry = "PP-E301";
inline constexpr std::string_view kRenumberRefused = "PP-E501";
inline constexpr std::string_view kUnitsRefused = "PP-E502";
inline constexpr std::string_view kLinearizeRefused = "PP-E503";
inline constexpr std::string_view kConvertedLineTooLong = "PP-E504";  ///< a converted line the controller would not read
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
inline constexpr std::string_view kToolLengthZ = "PP-U219";    // Z after a tool-length change the program does not state
inline constexpr std::string_view kCutterComp = "PP-U220";     // cutter radius compensation with a non-zero / unknown radius
inline constexpr std::string_view kToolOffsetAxis = "PP-U221"; // G43.1 offset along an axis other than Z
inline constexpr std::string_view kModalRestore = "PP-U222";   // LinuxCNC M72/M73 restore this version cannot follow
inline constexpr std::string_view kKlartextUnresolved = "PP-U260";  // Heidenhain Klartext construct not followed
// Lathe cycles (docs/lathe-cycles.md): PP-E250…259, PP-U250…259.
inline constexpr std::string_view kLatheCycleRejected = "PP-E250";  ///< the controller rejects the cycle
inline constexpr std::string_view kLatheProfileStatement = "PP-E251";  ///< statement inside a cycle's profile
inline constexpr std::string_view kLatheCycleUnresolved = "PP-U250";  ///< cycle word / profile form not followed
// Fanuc lathe turning cycles G70–G75, G90/G94, G77/G79 (docs/fanuc-turning-cycles.md).
inline constexpr std::string_view kFanucCycleAlarm = "PP-E252";      ///< the control stops with an alarm
inline constexpr std::string_view kFanucCycleUnresolved = "PP-U252"; ///< cycle form or profile content not followed
inline constexpr std::string_view kFanucCycleModal = "PP-U253";      ///< group-01 mode after G70–G73 not stated
// Threading cycles (docs/threading.md): PP-E256…259, PP-U256…259.
inline constexpr std::string_view kThreadingRejected = "PP-E256";    ///< the controller refuses the threading cycle
inline constexpr std::string_view kThreadingUnresolved = "PP-U256";  ///< threading cycle word / form not followed
inline constexpr std::string_view kThreadingParameter = "PP-U257";   ///< the cycle's path depends on a machine parameter the program does not state
// Fanuc dialect (docs/dialect-fanuc.md): constructs read only where they can be read exactly.
inline constexpr std::string_view kFanucPolar = "PP-U230";     ///< G16 polar command not read exactly
inline constexpr std::string_view kFanucScaling = "PP-U231";   ///< motion under G51 scaling
inline constexpr std::string_view kFanucMirror = "PP-U232";    ///< G51.1 mirror case not read exactly
inline constexpr std::string_view kFanucCorner = "PP-U233";    ///< ,C / ,R chamfer, corner rounding, direct drawing
inline constexpr std::string_view kFanucReturn = "PP-U234";    ///< G29 whose end point is not known
inline constexpr std::string_view kFanucSystemB = "PP-U235";   ///< U/W moves in lathe G-code system B
// Siemens dialect (reader round 2): Sinumerik motion addresses and declarations.
inline constexpr std::string_view kSiemensCorner = "PP-U240";     ///< CHF= CHR= RND= RNDM= not computed
inline constexpr std::string_view kSiemensSpaceArc = "PP-U241";   ///< CIP / CT arc not in a principal plane
inline constexpr std::string_view kSiemensGlobalVar = "PP-U242";  ///< GUD / undeclared variable read
inline constexpr std::string_view kSiemensTurnFraction = "PP-U243"; ///< TURN= not a whole number
inline constexpr std::string_view kSiemensArcWords = "PP-E240";   ///< AR= TURN= CR= I1= misused
inline constexpr std::string_view kSiemensGlobalFlow = "PP-E241";  ///< GUD value decides control flow / assignment
// The program's end (M2/M30, the closing '%').
inline constexpr std::string_view kAfterProgramEnd = "PP-W210";  ///< NC words after the end: never run
inline constexpr std::string_view kNoProgramEnd = "PP-W211";     ///< LinuxCNC file ends without M2/M30 or '%'
inline constexpr std::string_view kStrayPercent = "PP-E210";     ///< LinuxCNC '%' without an opening one
// Notes.
inline constexpr std::string_view kDialectGuess = "PP-N001";
inline constexpr std::string_view kDialectMismatch = "PP-N002";
inline constexpr std::string_view kTapeLeader = "PP-N003";
inline constexpr std::string_view kGCodeSystemFound = "PP-N004";  ///< Fanuc lathe G-code system read off the program
}  // namespace postproc::gcode::codes
