; The Klartext constructs of docs/dialect-heidenhain.md (TNC 640 User's Manual, "Programming contours")
0  BEGIN PGM BASIC MM
1  BLK FORM 0.1 Z  X+0  Y+0  Z-40
2  BLK FORM 0.2  X+100  Y+100  Z+0
3  ;-------------------------------------
4  * - Contour
5  TOOL CALL 1 Z S5000
6  L  Z+100 R0 FMAX M3
7  L  X-10  Y-10 R0 FMAX
8  L  Z+2 R0 FMAX
9  L  Z-5 R0 F200
10 L  X+0  Y+0 F500
11 L  X+50
12 CC X+50  Y+25
13 C  X+50  Y+50 DR+
14 CR X+20  Y+50 R+15 DR+
15 L  IX-20
16 CT X-10  Y+30
17 CC X+0  Y+0
18 LP PR+40 PA+45
19 CP IPA+90 DR+
20 CP IPA+720 IZ-4 DR+
21 L  Z+50 R0 FMAX
22 CYCL DEF 7.0 DATUM SHIFT
23 CYCL DEF 7.1 X+10
24 CYCL DEF 7.2 IY+5
25 L  X+0  Y+0 FMAX
26 L  Z+100 FMAX M30
27 END PGM BASIC MM
