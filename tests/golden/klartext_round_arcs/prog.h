; RND R between a line and an arc and between two arcs (TNC 640 User's Manual, "Rounding corners RND": the arc is
; tangent to the preceding and the following contour element; the arcs keep their centres); the CC of an arc may
; stand between the RND and the arc. Values worked by hand in tests/test_klartext.cpp (RoundingBetweenALineAndAnArc).
0  BEGIN PGM RNDARC MM
1  L  X+50  Y-30  Z+0 R0 FMAX
2  L  Y+0 F500
3  RND R5
4  CC X+50  Y+20
5  C  X+70  Y+20 DR+
6  RND R3
7  CC X+80  Y+30
8  C  X+90  Y+40 DR-
9  END PGM RNDARC MM
