; hyperMILL style: PLANE ... STAY leaves the rotary angles in Q120-Q122, which the next block reads.
; Expect PP-U213 at each word reading them: that block is not followed, A and C unknown until programmed;
; the program is accepted with unresolved constructs (exit 1). TNC 640 manual: PLANE STAY stores the
; rotary axis values in Q120 (A), Q121 (B), Q122 (C).
0  BEGIN PGM STAY MM
1  L  X+0  Y+0  Z+50 R0 FMAX
2  PLANE SPATIAL SPA90 SPB0 SPC180 STAY SEQ- TABLE ROT
3  L  A+Q120  C+Q122 R0 FMAX M126
4  L  X+10  Y+7 R0 F MAX
5  PLANE RESET STAY
6  L  A+0  C+0 R0 FMAX
7  END PGM STAY MM
