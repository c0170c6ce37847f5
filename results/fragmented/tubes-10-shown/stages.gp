set terminal pngcairo noenhanced size 900,600
set output '/work/scratch/frag-a033/tubes-10-shown/stages.png'
set title 'time per stage (step 0.5)'
set style data histograms
set style histogram rowstacked
set style fill solid 0.8
set ylabel 'ms'
set key outside
set grid y
set xtics rotate by -45 font ',8'
plot for [c=2:5] '/work/scratch/frag-a033/tubes-10-shown/stages.dat' using c:xtic(1) title columnheader

set terminal svg noenhanced size 900,600
set output '/work/scratch/frag-a033/tubes-10-shown/stages.svg'
set title 'time per stage (step 0.5)'
set style data histograms
set style histogram rowstacked
set style fill solid 0.8
set ylabel 'ms'
set key outside
set grid y
set xtics rotate by -45 font ',8'
plot for [c=2:5] '/work/scratch/frag-a033/tubes-10-shown/stages.dat' using c:xtic(1) title columnheader

