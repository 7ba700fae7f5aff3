G0 X1 Y2
G1 X3 (crlf)
G1 X4G1 X5


G1 X6