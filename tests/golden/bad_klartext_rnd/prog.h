; expect PP-U260 twice
; RND where the line and the arc meet tangentially (no corner) and CHF next to an arc (TNC 640: a chamfer
; joins two straight lines) are not built: refused at each, the moves beside them are not corrected
0  BEGIN PGM RND MM
1  TOOL CALL 1 Z S3000
2  L  X+0  Y+0  Z+5 R0 FMAX
3  L  X+50 F500
4  RND R5
5  CC X+50  Y+20
6  C  X+70  Y+20 DR+
7  L  Y+40
8  CHF 2
9  CC X+90  Y+40
10 C  X+90  Y+60 DR-
11 END PGM RND MM
