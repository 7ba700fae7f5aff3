; expect PP-U260
; RND next to an arc is not built yet (only between two straight moves): refused at the RND, the arc is not corrected
0  BEGIN PGM RND MM
1  TOOL CALL 1 Z S3000
2  L  X+0  Y+0  Z+5 R0 FMAX
3  L  X+50 F500
4  RND R5
5  CC X+50  Y+20
6  C  X+70  Y+20 DR+
7  END PGM RND MM
