; expect PP-E701 at the formula reading Q8 (a value left by an earlier program): the program is refused there
0  BEGIN PGM QUNSET MM
1  L  X+Q7  Y+0  Z+5 R0 FMAX
2  Q1 = Q8 * 2
3  L  X+Q1 FMAX
4  END PGM QUNSET MM
