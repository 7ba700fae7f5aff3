%
O0101 (GOLDEN: DWELL AND TOOL LENGTH CHANGES ARE NOT MOVES)
(Fanuc 0i-MF "Dwell (G04)": X is the time in seconds, never a position.)
("Tool length compensation": with parameter 5006#6 = 0 the G49 block moves Z itself;)
(the tip stays at the program Z, so the rapid after it keeps Z100.)
G21 G90 G94 G17 G54
T7 M6
G0 X0. Y0. Z150. B0. C0.
G43 H7 Z100.
G0 X40. Y-20. Z30. B-15. C30.
G1 Z20. F800.
G04 X200.
G1 X35.5 Y-12.25 Z19.5 B-18.5 C42.
G0 Z100.
G49
G0 X10. Y10.
M30
%
