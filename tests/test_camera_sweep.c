#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "leap/renderer.h"
#include "leap/scene.h"
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+t.tv_nsec*1e-9;}
int main(int argc,char**argv){
  leap_error err={{0}};
  leap_scene *s=NULL; leap_scene_desc d={.path=argv[1]};
  if(leap_scene_create(&d,&s,&err)){printf("%s\n",err.msg);return 1;}
  leap_renderer *r=NULL; leap_renderer_desc rd={.event_pool=(unsigned)atoi(argv[3]), .max_segments=(unsigned)atoi(argv[4])};
  if(leap_renderer_create(&rd,&r,&err)){printf("%s\n",err.msg);return 1;}
  leap_renderer_set_volume(r,s->atlas,&err); leap_renderer_set_tf(r,&s->tf,&err);
  leap_renderer_set_occupancy(r,s->occupancy,s->boxes);
  int W=atoi(argv[2]); float *img=malloc(W*W*16);
  for(int m=0;m<3;m++){
    double t0=now(); int N=200;
    for(int i=0;i<N;i++){
      leap_camera cam; leap_camera_orbit(s->center,s->radius,i*7.3,i*3.1-30,0,40,0,&cam,&err);
      leap_view v; leap_scene_view(s,&cam,W,W,&v,&err);
      leap_frame_stats st; if(leap_renderer_render(r,&v,&s->march,m,img,NULL,NULL,&st,&err)){printf("%s\n",err.msg);return 1;}
      if(i==N-1) printf("up %.2f ord %.2f render %.2f raster %.2f resolve %.2f comp %.2f rb %.2f\n",st.upload_ms,st.order_ms,st.render_ms,st.gpu_raster_ms,st.gpu_resolve_ms,st.gpu_composite_ms,st.readback_ms);
    }
    printf("mode %d: %.3f ms/render boxes %u\n",m,(now()-t0)/N*1e3, leap_boxes_count(s->boxes));
  }
  leap_renderer_destroy(r); leap_scene_destroy(s); return 0;
}
