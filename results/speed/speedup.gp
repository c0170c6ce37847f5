set terminal pngcairo size 900,600
set output 'results/speed/speedup.png'
set title 'speedup over naive (step 0.5)'
set style data histograms
set style fill solid 0.8
set ylabel 'x naive frame time'
set logscale y
set key outside
set grid y
set xtics rotate by -20
plot for [c=2:4] 'results/speed/speedup.dat' using c:xtic(1) title columnheader

set terminal svg size 900,600
set output 'results/speed/speedup.svg'
set title 'speedup over naive (step 0.5)'
set style data histograms
set style fill solid 0.8
set ylabel 'x naive frame time'
set logscale y
set key outside
set grid y
set xtics rotate by -20
plot for [c=2:4] 'results/speed/speedup.dat' using c:xtic(1) title columnheader

