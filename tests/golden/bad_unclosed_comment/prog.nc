(expect PP-E102)
G21 G90 G0 X0 Y0
G1 X10 (feed move F100
M30
