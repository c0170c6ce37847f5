set terminal pngcairo noenhanced size 900,600
set output 'results/noisy-scan/speed_error_0.png'
set title 'speed against error: ch2noisy.vdb (512x512)'
set xlabel 'RMSE against reference'
set ylabel 'frame ms (median over views)'
set logscale xy
set key outside
set grid
plot 'results/noisy-scan/speed_error_0.dat' index 0 using 1:2 with linespoints title 'naive', 'results/noisy-scan/speed_error_0.dat' index 1 using 1:2 with linespoints title 'bbox', 'results/noisy-scan/speed_error_0.dat' index 2 using 1:2 with linespoints title 'octree', 'results/noisy-scan/speed_error_0.dat' index 3 using 1:2 with linespoints title 'sparseleap'
set terminal svg noenhanced size 900,600
set output 'results/noisy-scan/speed_error_0.svg'
set title 'speed against error: ch2noisy.vdb (512x512)'
set xlabel 'RMSE against reference'
set ylabel 'frame ms (median over views)'
set logscale xy
set key outside
set grid
plot 'results/noisy-scan/speed_error_0.dat' index 0 using 1:2 with linespoints title 'naive', 'results/noisy-scan/speed_error_0.dat' index 1 using 1:2 with linespoints title 'bbox', 'results/noisy-scan/speed_error_0.dat' index 2 using 1:2 with linespoints title 'octree', 'results/noisy-scan/speed_error_0.dat' index 3 using 1:2 with linespoints title 'sparseleap'
