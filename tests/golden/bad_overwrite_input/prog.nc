(expect exit 64: the output would overwrite the input)
G0 X1
M30
