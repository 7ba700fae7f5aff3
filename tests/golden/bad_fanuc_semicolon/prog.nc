(expect PP-E101)
G0 X0 ; a Siemens-style comment
M30
