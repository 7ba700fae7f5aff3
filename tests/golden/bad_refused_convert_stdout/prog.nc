(expect PP-E102)
G0 X0
G1 X1 (open
M30
