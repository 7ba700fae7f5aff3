(expect PP-E620)
(postproc 0.1.0 compensate mode=geometric machine=machine.toml sha256=0123456789abcdef)
G21 G90 G54
G0 X0. Y0. Z100. B0. C0.
G1 X10. F1000.
M30
