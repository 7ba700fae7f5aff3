(expect PP-E202: LinuxCNC refuses two G codes of one modal group; Fanuc takes the last)
N10 G21 G90 G0 X0 Y0
N20 G0 G1 X5 F100
N30 M30
