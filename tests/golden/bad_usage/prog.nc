(expect exit 64: convert without -o)
G0 X1
M30
