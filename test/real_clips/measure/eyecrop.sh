#!/bin/bash
# Eye check: crop of frame <i> of <clip> centred at (cx, cy), half-size h, magnified s times, with a grid line every
# <g> source pixels (labelled with absolute pixel coordinates) and a small green cross at the measured position (mx, my).
# usage: eyecrop.sh clip i cx cy h s g mx my out.png
clip=$1 i=$2 cx=$3 cy=$4 h=$5 s=$6 g=$7 mx=$8 my=$9 out=${10}
x0=$(( ${cx%.*} - h )); y0=$(( ${cy%.*} - h )); [ $x0 -lt 0 ] && x0=0; [ $y0 -lt 0 ] && y0=0
f=$(printf "/tmp/clips/%s/f%05d.ppm" "$clip" "$i")
draw=""
for ((v = (x0 / g + 1) * g; v < x0 + 2 * h; v += g)); do p=$(( (v - x0) * s )); draw+=" -draw \"line $p,0 $p,$((2*h*s))\" -draw \"text $((p+2)),10 '$v'\""; done
for ((v = (y0 / g + 1) * g; v < y0 + 2 * h; v += g)); do p=$(( (v - y0) * s )); draw+=" -draw \"line 0,$p $((2*h*s)),$p\" -draw \"text 2,$((p-2)) '$v'\""; done
mxs=$(/usr/bin/python3 -c "print(round(($mx-$x0+0.5)*$s), round(($my-$y0+0.5)*$s))")
set -- $mxs
eval convert -font /usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf -pointsize 11 "$f" -crop $((2*h))x$((2*h))+$x0+$y0 +repage -filter point -resize $((100*s))% \
  -fill "'rgba(0,0,255,0.8)'" -stroke "'rgba(0,0,255,0.45)'" $draw \
  -stroke lime -draw "\"line $(($1-6)),$2 $(($1+6)),$2\"" -draw "\"line $1,$(($2-6)) $1,$(($2+6))\"" \
  -stroke none -fill red -draw "\"text 4,$((2*h*s-4)) 'f$i'\"" "$out"
