set terminal pngcairo noenhanced size 900,600
set output '/work/scratch/frag-a033/tubes-10-shown/speedup.png'
set title 'speedup over naive (step 0.5)'
set style data histograms
set style fill solid 0.8
set ylabel 'x naive frame time'
set logscale y
set yrange [0.5:*]
set key outside
set grid y
set xtics rotate by -20
plot for [c=2:4] '/work/scratch/frag-a033/tubes-10-shown/speedup.dat' using c:xtic(1) title columnheader

set terminal svg noenhanced size 900,600
set output '/work/scratch/frag-a033/tubes-10-shown/speedup.svg'
set title 'speedup over naive (step 0.5)'
set style data histograms
set style fill solid 0.8
set ylabel 'x naive frame time'
set logscale y
set yrange [0.5:*]
set key outside
set grid y
set xtics rotate by -20
plot for [c=2:4] '/work/scratch/frag-a033/tubes-10-shown/speedup.dat' using c:xtic(1) title columnheader

