; RND R (tangent arc) and CHF L (equal legs) between straight moves shorten both moves (TNC 640 User's Manual, "Rounding corners RND", "Chamfer CHF"); corners chain; an RND larger than its moves is refused
0  BEGIN PGM RNDCHF MM
1  TOOL CALL 1 Z S3000
2  L  X+0  Y+0  Z+5 R0 FMAX
3  L  Z-2 F200
4  L  X+50 F500
5  RND R5
6  L  Y+40
7  CHF 10
8  L  X+0
9  RND R5 F100
10 L  Y+0
11 RND R100
12 L  X+50
13 L  Z+50 FMAX M30
14 END PGM RNDCHF MM
